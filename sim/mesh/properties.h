#pragma once
// Per-element properties that grow with the mesh (after pmp-library's design):
// every element kind keeps a container of named, typed arrays that are resized,
// copied and compacted together with the element count.
#include <algorithm>
#include <cassert>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <type_traits>
#include <typeinfo>
#include <utility>
#include <vector>

#include "sim/mesh/mesh_error.h"
#include "sim/mesh/small_vector.h"

namespace ld::mesh {

// How a property array is copied with its mesh. Lists per element (a vertex's edges)
// get a little room beyond their length, since edits near them add an edge or two:
// without it, the first edit next to each vertex of a copied mesh reallocates its list.
// Same number of allocations as a plain copy.
template <class T>
void copyPropertyData(const std::vector<T>& from, std::vector<T>& to) {
  to = from;
}
// (Only a list longer than an empty copy's room gets the slack: inline lists stay inline.)
template <class List>
void copyListsWithSlack(const std::vector<List>& from, std::vector<List>& to) {
  constexpr std::size_t kSlack = 4;
  to.clear();
  to.reserve(from.size());
  for (const auto& list : from) {
    auto& copy = to.emplace_back();
    if (list.size() > copy.capacity()) copy.reserve(list.size() + kSlack);
    copy.assign(list.begin(), list.end());
  }
}
template <class E>
void copyPropertyData(const std::vector<std::vector<E>>& from, std::vector<std::vector<E>>& to) {
  copyListsWithSlack(from, to);
}
template <class E, std::uint32_t N>
void copyPropertyData(const std::vector<SmallVector<E, N>>& from, std::vector<SmallVector<E, N>>& to) {
  copyListsWithSlack(from, to);
}

class BasePropertyArray {
 public:
  explicit BasePropertyArray(std::string name) : name_(std::move(name)) {}
  virtual ~BasePropertyArray() = default;
  virtual void resize(std::size_t n) = 0;
  virtual void reserve(std::size_t n) = 0;
  // Writes the room past the last element once (defaults, discarded at once), so that
  // elements appended there later do not take the first-touch page faults.
  virtual void touchReserved() = 0;
  virtual void pushBack() = 0;
  // Appends a copy of element `from` (pushBack then copyElement, in one pass).
  virtual void pushBackCopy(std::size_t from) = 0;
  virtual void copyElement(std::size_t from, std::size_t to) = 0;
  // Keeps element old[i] at position i for i < keep.size().
  virtual void compact(const std::vector<std::size_t>& keep) = 0;
  // A new array holding the elements `idx` (in that order).
  [[nodiscard]] virtual std::unique_ptr<BasePropertyArray> gather(const std::vector<std::size_t>& idx) const = 0;
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
  void reserve(std::size_t n) override { data_.reserve(n); }
  void touchReserved() override {
    const std::size_t n = data_.size();
    data_.resize(data_.capacity(), default_);  // within the capacity: no reallocation
    data_.resize(n);
  }
  void pushBack() override { data_.push_back(default_); }
  void pushBackCopy(std::size_t from) override {
    if constexpr (std::is_same_v<T, bool>) {
      data_.push_back(static_cast<bool>(data_[from]));
    } else {
      data_.push_back(data_[from]);  // std::vector copes with an element of its own
    }
  }
  void copyElement(std::size_t from, std::size_t to) override { data_[to] = data_[from]; }
  void compact(const std::vector<std::size_t>& keep) override {
    std::vector<T> out;
    out.reserve(keep.size());
    for (std::size_t i : keep) out.push_back(std::move(data_[i]));
    data_.swap(out);
  }
  [[nodiscard]] std::unique_ptr<BasePropertyArray> gather(const std::vector<std::size_t>& idx) const override {
    auto p = std::make_unique<PropertyArray<T>>(name(), default_);
    p->data_.reserve(idx.size());
    for (std::size_t i : idx) p->data_.push_back(data_[i]);
    return p;
  }
  [[nodiscard]] std::unique_ptr<BasePropertyArray> clone() const override {
    auto p = std::make_unique<PropertyArray<T>>(name(), default_);
    copyPropertyData(data_, p->data_);
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
  // Copies hold exactly their elements; the first growth reserves for all arrays.
  PropertyContainer(const PropertyContainer& o) : size_(o.size_), capacity_(o.size_) {
    for (const auto& a : o.arrays_) arrays_.push_back(a->clone());
  }
  PropertyContainer& operator=(const PropertyContainer& o) {
    if (this != &o) {
      PropertyContainer tmp(o);
      std::swap(arrays_, tmp.arrays_);
      size_ = o.size_;
      capacity_ = o.size_;
    }
    return *this;
  }
  PropertyContainer(PropertyContainer&& o) noexcept
      : arrays_(std::move(o.arrays_)), size_(std::exchange(o.size_, 0)), capacity_(std::exchange(o.capacity_, 0)) {}
  PropertyContainer& operator=(PropertyContainer&& o) noexcept {
    arrays_ = std::move(o.arrays_);
    size_ = std::exchange(o.size_, 0);
    capacity_ = std::exchange(o.capacity_, 0);
    return *this;
  }

  template <class T>
  PropertyArray<T>* add(const std::string& name, T def) {
    if (find(name)) throw PropertyError("property '" + name + "' already exists");
    auto a = std::make_unique<PropertyArray<T>>(name, std::move(def));
    a->reserve(capacity_);
    a->resize(size_);
    auto* raw = a.get();
    arrays_.push_back(std::move(a));
    return raw;
  }
  template <class T>
  PropertyArray<T>* get(std::string_view name) const {
    BasePropertyArray* a = find(name);
    if (!a) return nullptr;
    if (a->type() != typeid(T)) throw PropertyError("property '" + std::string(name) + "' has another type");
    return static_cast<PropertyArray<T>*>(a);
  }
  void remove(const std::string& name) {
    std::erase_if(arrays_, [&](const auto& a) { return a->name() == name; });
  }
  [[nodiscard]] bool exists(std::string_view name) const { return find(name) != nullptr; }
  [[nodiscard]] std::vector<std::string> names() const {
    std::vector<std::string> n;
    for (const auto& a : arrays_) n.push_back(a->name());
    return n;
  }

  // Grows every array together and geometrically, so that an edit adding one element
  // reallocates all arrays at once, rarely, instead of each at its own moment.
  void pushBack() {
    roomForOne();
    for (auto& a : arrays_) a->pushBack();
    ++size_;
  }
  // The same for an owner that knows the types of the first `typed` arrays (a mesh's
  // built-ins, always added first): every array gets room first, then `push` appends
  // exactly one element to each of those arrays itself (no virtual call, and their
  // values at once rather than defaults), and the other arrays get their default.
  template <class Push>
  void pushBackTyped(std::size_t typed, Push&& push) {
    assert(typed <= arrays_.size());
    roomForOne();
    push();
    for (std::size_t i = typed; i < arrays_.size(); ++i) arrays_[i]->pushBack();
    ++size_;
  }
  // As pushBackTyped, the other arrays getting a copy of element `from`.
  template <class Push>
  void pushBackCopyTyped(std::size_t typed, std::size_t from, Push&& push) {
    assert(typed <= arrays_.size() && from < size_);
    roomForOne();
    push();
    for (std::size_t i = typed; i < arrays_.size(); ++i) arrays_[i]->pushBackCopy(from);
    ++size_;
  }
  // The i-th array in the order of add() (removals keep the others' order).
  [[nodiscard]] const BasePropertyArray& array(std::size_t i) const { return *arrays_[i]; }
  [[nodiscard]] std::size_t arrayCount() const { return arrays_.size(); }
  void resize(std::size_t n) {
    for (auto& a : arrays_) a->resize(n);
    size_ = n;
    capacity_ = std::max(capacity_, n);
  }
  void reserve(std::size_t n) {
    if (n <= capacity_) return;
    for (auto& a : arrays_) a->reserve(n);
    capacity_ = n;
  }
  void touchReserved() {
    for (auto& a : arrays_) a->touchReserved();
  }
  void copyElement(std::size_t from, std::size_t to) {
    for (auto& a : arrays_) a->copyElement(from, to);
  }
  // A new last element, a copy of `from`.
  void pushBackCopy(std::size_t from) {
    roomForOne();
    for (auto& a : arrays_) a->pushBackCopy(from);
    ++size_;
  }
  void compact(const std::vector<std::size_t>& keep) {
    for (auto& a : arrays_) a->compact(keep);
    size_ = keep.size();
    capacity_ = size_;
  }
  // A container with the same properties holding only the elements `idx` (in that
  // order): copying part of a mesh costs in proportion to the part.
  [[nodiscard]] PropertyContainer gather(const std::vector<std::size_t>& idx) const {
    PropertyContainer out;
    for (const auto& a : arrays_) out.arrays_.push_back(a->gather(idx));
    out.size_ = idx.size();
    out.capacity_ = idx.size();
    return out;
  }
  [[nodiscard]] std::size_t size() const { return size_; }
  // Every array can hold this many elements without reallocating.
  [[nodiscard]] std::size_t capacity() const { return capacity_; }

 private:
  // Grows every array together and geometrically before one more element (pushBack).
  void roomForOne() {
    if (size_ == capacity_) reserve(std::max<std::size_t>(16, 2 * capacity_));
  }
  // By name, without making a string of it (the lookups take literals).
  BasePropertyArray* find(std::string_view name) const {
    for (const auto& a : arrays_)
      if (a->name() == name) return a.get();
    return nullptr;
  }
  std::vector<std::unique_ptr<BasePropertyArray>> arrays_;
  std::size_t size_ = 0;
  std::size_t capacity_ = 0;  // a lower bound of every array's capacity
};

}  // namespace ld::mesh
