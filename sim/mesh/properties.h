#pragma once
// Per-element properties that grow with the mesh (after pmp-library's design):
// every element kind keeps a container of named, typed arrays that are resized,
// copied and compacted together with the element count.
#include <algorithm>
#include <cassert>
#include <memory>
#include <string>
#include <typeinfo>
#include <utility>
#include <vector>

#include "sim/mesh/mesh_error.h"

namespace ld::mesh {

class BasePropertyArray {
 public:
  explicit BasePropertyArray(std::string name) : name_(std::move(name)) {}
  virtual ~BasePropertyArray() = default;
  virtual void resize(std::size_t n) = 0;
  virtual void pushBack() = 0;
  virtual void copyElement(std::size_t from, std::size_t to) = 0;
  // Keeps element old[i] at position i for i < keep.size().
  virtual void compact(const std::vector<std::size_t>& keep) = 0;
  [[nodiscard]] virtual std::unique_ptr<BasePropertyArray> clone() const = 0;
  [[nodiscard]] virtual const std::type_info& type() const = 0;
  [[nodiscard]] const std::string& name() const { return name_; }

 private:
  std::string name_;
};

template <class T>
class PropertyArray final : public BasePropertyArray {
 public:
  PropertyArray(std::string name, T def) : BasePropertyArray(std::move(name)), default_(std::move(def)) {}
  void resize(std::size_t n) override { data_.resize(n, default_); }
  void pushBack() override { data_.push_back(default_); }
  void copyElement(std::size_t from, std::size_t to) override { data_[to] = data_[from]; }
  void compact(const std::vector<std::size_t>& keep) override {
    std::vector<T> out;
    out.reserve(keep.size());
    for (std::size_t i : keep) out.push_back(std::move(data_[i]));
    data_.swap(out);
  }
  [[nodiscard]] std::unique_ptr<BasePropertyArray> clone() const override {
    auto p = std::make_unique<PropertyArray<T>>(name(), default_);
    p->data_ = data_;
    return p;
  }
  [[nodiscard]] const std::type_info& type() const override { return typeid(T); }
  std::vector<T>& vector() { return data_; }
  const std::vector<T>& vector() const { return data_; }

 private:
  std::vector<T> data_;
  T default_;
};

// A typed view of one property array. Cheap to copy; invalidated when the
// property is removed or the owning mesh is destroyed, not when it grows.
template <class H, class T>
class Property {
 public:
  Property() = default;
  explicit Property(PropertyArray<T>* a) : array_(a) {}
  [[nodiscard]] bool isValid() const { return array_ != nullptr; }
  explicit operator bool() const { return isValid(); }
  decltype(auto) operator[](H h) {
    assert(array_ && h.idx() < array_->vector().size());
    return array_->vector()[h.idx()];
  }
  decltype(auto) operator[](H h) const {
    assert(array_ && h.idx() < array_->vector().size());
    return std::as_const(array_->vector())[h.idx()];
  }
  std::vector<T>& vector() { return array_->vector(); }
  const std::vector<T>& vector() const { return array_->vector(); }
  [[nodiscard]] const std::string& name() const { return array_->name(); }

 private:
  PropertyArray<T>* array_ = nullptr;
};

class PropertyContainer {
 public:
  PropertyContainer() = default;
  PropertyContainer(const PropertyContainer& o) : size_(o.size_) {
    for (const auto& a : o.arrays_) arrays_.push_back(a->clone());
  }
  PropertyContainer& operator=(const PropertyContainer& o) {
    if (this != &o) {
      PropertyContainer tmp(o);
      std::swap(arrays_, tmp.arrays_);
      size_ = o.size_;
    }
    return *this;
  }
  PropertyContainer(PropertyContainer&&) noexcept = default;
  PropertyContainer& operator=(PropertyContainer&&) noexcept = default;

  template <class T>
  PropertyArray<T>* add(const std::string& name, T def) {
    if (find(name)) throw PropertyError("property '" + name + "' already exists");
    auto a = std::make_unique<PropertyArray<T>>(name, std::move(def));
    a->resize(size_);
    auto* raw = a.get();
    arrays_.push_back(std::move(a));
    return raw;
  }
  template <class T>
  PropertyArray<T>* get(const std::string& name) const {
    BasePropertyArray* a = find(name);
    if (!a) return nullptr;
    if (a->type() != typeid(T)) throw PropertyError("property '" + name + "' has another type");
    return static_cast<PropertyArray<T>*>(a);
  }
  void remove(const std::string& name) {
    std::erase_if(arrays_, [&](const auto& a) { return a->name() == name; });
  }
  [[nodiscard]] bool exists(const std::string& name) const { return find(name) != nullptr; }
  [[nodiscard]] std::vector<std::string> names() const {
    std::vector<std::string> n;
    for (const auto& a : arrays_) n.push_back(a->name());
    return n;
  }

  void pushBack() {
    for (auto& a : arrays_) a->pushBack();
    ++size_;
  }
  void resize(std::size_t n) {
    for (auto& a : arrays_) a->resize(n);
    size_ = n;
  }
  void reserve(std::size_t) {}
  void copyElement(std::size_t from, std::size_t to) {
    for (auto& a : arrays_) a->copyElement(from, to);
  }
  void compact(const std::vector<std::size_t>& keep) {
    for (auto& a : arrays_) a->compact(keep);
    size_ = keep.size();
  }
  [[nodiscard]] std::size_t size() const { return size_; }

 private:
  BasePropertyArray* find(const std::string& name) const {
    for (const auto& a : arrays_)
      if (a->name() == name) return a.get();
    return nullptr;
  }
  std::vector<std::unique_ptr<BasePropertyArray>> arrays_;
  std::size_t size_ = 0;
};

}  // namespace ld::mesh
