#pragma once
// The file index of each Gaussian a splat reader kept, from the indices it left out
// (SplatFileReport::dropped, PlyGaussianReport::dropped_vertices: ascending). A reader keeps
// the rest in file order, so the k-th kept Gaussian is the k-th file index not left out:
// what its id is, which line of a labels file is its label, which vertex a message names.
#include <cstddef>
#include <span>

namespace gauss {

class KeptFileIndices {
 public:
  explicit KeptFileIndices(std::span<const std::size_t> dropped) : dropped_(dropped) {}
  // The next kept Gaussian's index in the file (the first call: the first kept one's).
  std::size_t next() {
    while (d_ < dropped_.size() && dropped_[d_] == index_) {
      ++index_;
      ++d_;
    }
    return index_++;
  }

 private:
  std::span<const std::size_t> dropped_;
  std::size_t d_{0};      // dropped_[d_] is the next index left out
  std::size_t index_{0};  // the next file index to consider
};

}  // namespace gauss
