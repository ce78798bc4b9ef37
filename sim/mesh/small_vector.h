#pragma once
// A vector of trivially copyable elements that keeps its first N elements inside
// itself and moves to the heap only beyond them. A vertex's edge list lives this way
// in the vertex array: reading it follows no pointer, and a new vertex costs no
// allocation. The order of elements follows std::vector's for every operation here.
#include <algorithm>
#include <cassert>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <iterator>
#include <new>
#include <type_traits>

namespace ld::mesh {

template <class T, std::uint32_t N>
class SmallVector {
  static_assert(std::is_trivially_copyable_v<T> && std::is_trivially_destructible_v<T>);
  static_assert(N > 0 && N * sizeof(T) >= sizeof(T*));

 public:
  using value_type = T;
  using size_type = std::size_t;
  using difference_type = std::ptrdiff_t;
  using reference = T&;
  using const_reference = const T&;
  using pointer = T*;
  using const_pointer = const T*;
  using iterator = T*;
  using const_iterator = const T*;

  SmallVector() noexcept = default;
  SmallVector(const SmallVector& o) { assign(o.begin(), o.end()); }
  SmallVector(SmallVector&& o) noexcept { steal(o); }
  SmallVector& operator=(const SmallVector& o) {
    if (this != &o) assign(o.begin(), o.end());
    return *this;
  }
  SmallVector& operator=(SmallVector&& o) noexcept {
    if (this != &o) {
      release();
      steal(o);
    }
    return *this;
  }
  ~SmallVector() { release(); }

  [[nodiscard]] bool onHeap() const noexcept { return cap_ > N; }
  [[nodiscard]] T* data() noexcept { return onHeap() ? heap_ : reinterpret_cast<T*>(local_); }
  [[nodiscard]] const T* data() const noexcept { return onHeap() ? heap_ : reinterpret_cast<const T*>(local_); }
  [[nodiscard]] iterator begin() noexcept { return data(); }
  [[nodiscard]] iterator end() noexcept { return data() + size_; }
  [[nodiscard]] const_iterator begin() const noexcept { return data(); }
  [[nodiscard]] const_iterator end() const noexcept { return data() + size_; }
  [[nodiscard]] const_iterator cbegin() const noexcept { return begin(); }
  [[nodiscard]] const_iterator cend() const noexcept { return end(); }
  [[nodiscard]] size_type size() const noexcept { return size_; }
  [[nodiscard]] size_type capacity() const noexcept { return cap_; }
  [[nodiscard]] bool empty() const noexcept { return size_ == 0; }

  T& operator[](size_type i) noexcept {
    assert(i < size_);
    return data()[i];
  }
  const T& operator[](size_type i) const noexcept {
    assert(i < size_);
    return data()[i];
  }
  T& front() noexcept { return (*this)[0]; }
  const T& front() const noexcept { return (*this)[0]; }
  T& back() noexcept { return (*this)[size_ - 1]; }
  const T& back() const noexcept { return (*this)[size_ - 1]; }

  void push_back(const T& x) {
    if (size_ == cap_) [[unlikely]] {
      const T copy = x;  // x may be an element of this vector
      grow(2 * static_cast<size_type>(cap_));
      data()[size_++] = copy;
      return;
    }
    data()[size_++] = x;
  }
  void pop_back() noexcept {
    assert(size_ > 0);
    --size_;
  }
  void clear() noexcept { size_ = 0; }
  void reserve(size_type n) {
    if (n > cap_) grow(n);
  }
  // New elements are value-initialised, as std::vector's.
  void resize(size_type n) { resize(n, T()); }
  void resize(size_type n, const T& x) {
    reserve(n);
    T* d = data();
    for (size_type i = size_; i < n; ++i) d[i] = x;
    size_ = static_cast<std::uint32_t>(n);
  }
  template <class It>
  void assign(It first, It last) {
    const auto n = static_cast<size_type>(std::distance(first, last));
    size_ = 0;
    reserve(n);
    std::copy(first, last, data());
    size_ = static_cast<std::uint32_t>(n);
  }
  // Removes the elements matching `pred`, keeping the others' order; returns how many.
  template <class Pred>
  size_type eraseIf(Pred pred) {
    T* d = data();
    T* kept = std::remove_if(d, d + size_, pred);
    const auto removed = static_cast<size_type>(d + size_ - kept);
    size_ = static_cast<std::uint32_t>(kept - d);
    return removed;
  }

  friend bool operator==(const SmallVector& a, const SmallVector& b) {
    return a.size_ == b.size_ && std::equal(a.begin(), a.end(), b.begin());
  }

 private:
  [[gnu::noinline]] void grow(size_type n) {
    auto* fresh = static_cast<T*>(::operator new(n * sizeof(T)));
    if (size_ > 0) std::memcpy(fresh, data(), size_ * sizeof(T));
    release();
    heap_ = fresh;
    cap_ = static_cast<std::uint32_t>(n);
  }
  void release() noexcept {
    if (onHeap()) ::operator delete(heap_);
    cap_ = N;
  }
  // Takes o's elements (its heap block, or a copy of its inline ones); o is left empty.
  void steal(SmallVector& o) noexcept {
    size_ = o.size_;
    cap_ = o.cap_;
    std::memcpy(local_, o.local_, sizeof(local_));
    o.size_ = 0;
    o.cap_ = N;
  }

  std::uint32_t size_ = 0;
  std::uint32_t cap_ = N;
  union {
    alignas(T) unsigned char local_[N * sizeof(T)];
    T* heap_;
  };
};

}  // namespace ld::mesh
