#pragma once
// detail::IdIndex, the flat GaussianId -> index table DesiredState and SlotTable look ids
// up in, and the allocator that puts such tables on transparent huge pages.
#include <cstddef>
#include <cstdint>
#include <vector>

namespace gauss {

namespace detail {

// Allocator for large tables read at random (the coalescing tables, the LoD pools, the
// scene store's Gaussians): blocks of 4 MiB and more are 2 MiB aligned and, on Linux,
// advised onto transparent huge pages. Coalescing touches one random index cell and one
// random entry per edit; over hundreds of megabytes of 4 KiB pages nearly every touch also
// misses the TLB, and the page walk costs about as much as the miss itself.
void* alloc_table(std::size_t bytes, std::size_t align);
void free_table(void* p, std::size_t bytes, std::size_t align) noexcept;

template <class T>
struct TableAllocator {
  using value_type = T;
  TableAllocator() noexcept = default;
  template <class U>
  TableAllocator(const TableAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) { return static_cast<T*>(alloc_table(n * sizeof(T), alignof(T))); }
  void deallocate(T* p, std::size_t n) noexcept { free_table(p, n * sizeof(T), alignof(T)); }
  template <class U>
  bool operator==(const TableAllocator<U>&) const noexcept { return true; }
};

// A vector on such blocks.
template <class T>
using TableVector = std::vector<T, TableAllocator<T>>;

// IdIndex: GaussianId -> entry index, an open-addressing hash table with linear
// probing and backward-shift deletion. The client's coalescing does one lookup per
// received edit into a table of up to M ids; std::unordered_map costs a node (a second
// cache miss) per lookup, this costs one probe run in one flat array of (key, value)
// cells (key and value side by side: one cache miss per lookup, not two).
// The id 2^64 - 1 marks an empty cell and cannot be stored (DesiredState rejects it).

class IdIndex {
 public:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};

  std::size_t size() const noexcept { return count_; }
  // The table's bytes (its cells; kCellBytes each).
  std::size_t bytes() const noexcept { return cells_.capacity() * kCellBytes; }

  // Pointer to the value of key, or nullptr.
  std::uint32_t* find(std::uint64_t key) {
    if (cells_.empty()) return nullptr;
    for (std::size_t i = slot(key);; i = (i + 1) & mask_) {
      if (cells_[i].key == key) return &cells_[i].value;
      if (cells_[i].key == kEmpty) return nullptr;
    }
  }
  const std::uint32_t* find(std::uint64_t key) const { return const_cast<IdIndex*>(this)->find(key); }

  // Asks the cache for the cell where a lookup of key starts (batched lookups issue
  // this a few edits ahead so the miss overlaps other work).
  // Unconditional on purpose: GCC drops a prefetch guarded by a branch that does
  // nothing else. On an empty table this prefetches data() + 0, which never faults.
  void prefetch(std::uint64_t key) const { __builtin_prefetch(cells_.data() + slot(key), 0, 3); }

  // Inserts or overwrites.
  void set(std::uint64_t key, std::uint32_t value) {
    if ((count_ + 1) * 2 > cells_.size()) grow();
    for (std::size_t i = slot(key);; i = (i + 1) & mask_) {
      if (cells_[i].key == key) {
        cells_[i].value = value;
        return;
      }
      if (cells_[i].key == kEmpty) {
        cells_[i] = Cell{key, value};
        ++count_;
        return;
      }
    }
  }

  // Removes key if present. Backward shift keeps every probe run unbroken.
  void erase(std::uint64_t key) {
    if (cells_.empty()) return;
    std::size_t i = slot(key);
    while (cells_[i].key != key) {
      if (cells_[i].key == kEmpty) return;
      i = (i + 1) & mask_;
    }
    for (std::size_t j = (i + 1) & mask_;; j = (j + 1) & mask_) {
      if (cells_[j].key == kEmpty) break;
      const std::size_t home = slot(cells_[j].key);
      // Move j back to i when i lies cyclically in [home, j).
      if (((j - home) & mask_) >= ((j - i) & mask_)) {
        cells_[i] = cells_[j];
        i = j;
      }
    }
    cells_[i].key = kEmpty;
    --count_;
  }

  void reserve(std::size_t n) {
    while (n * 2 > cells_.size()) grow();
  }

  template <class F>
  void for_each(F&& f) const {
    for (const Cell& c : cells_)
      if (c.key != kEmpty) f(c.key, c.value);
  }

 private:
  struct Cell {
    std::uint64_t key{kEmpty};
    std::uint32_t value{0};
  };

 public:
  static constexpr std::size_t kCellBytes = sizeof(Cell);

 private:

  std::size_t slot(std::uint64_t key) const {
    // Fibonacci hashing: host ids are often dense runs; multiply-shift spreads them.
    return static_cast<std::size_t>((key * 0x9e3779b97f4a7c15ull) >> shift_) & mask_;
  }
  void grow() {
    std::vector<Cell, TableAllocator<Cell>> old;
    old.swap(cells_);
    const std::size_t cap = old.empty() ? 64 : old.size() * 2;
    cells_.assign(cap, Cell{});
    mask_ = cap - 1;
    int bits = 0;
    while ((std::size_t{1} << bits) < cap) ++bits;
    shift_ = 64 - bits;
    count_ = 0;
    for (const Cell& c : old)
      if (c.key != kEmpty) set(c.key, c.value);
  }

  std::vector<Cell, TableAllocator<Cell>> cells_;
  std::size_t count_{0};
  std::size_t mask_{0};
  int shift_{63};  // with mask_ 0 every key maps to cell 0 (and the shift stays defined)
};

}  // namespace detail

}  // namespace gauss
