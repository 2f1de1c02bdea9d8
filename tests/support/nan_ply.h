#pragma once
// A scene as an ASCII 3DGS PLY in which chosen vertices have x = nan: what a trainer that
// diverged writes. Empty when the cloud cannot be encoded (a test asserts it is not).
#include <cstddef>
#include <string>

#include "gauss/engine/ply_gaussian.h"

namespace gauss::test {

template <class NanAt>  // bool nan_at(std::size_t vertex)
std::string ascii_ply_with_nans(const GaussianCloud& cloud, NanAt nan_at) {
  PlyGaussianWriteOptions o;
  o.format = PlyFormat::Ascii;
  auto bytes = encode_gaussian_ply(cloud, o);
  if (!bytes.ok()) return {};
  std::string text(bytes->begin(), bytes->end());
  std::size_t line = text.find("end_header\n") + 11;
  for (std::size_t v = 0; v < cloud.gaussians.size(); ++v) {
    if (nan_at(v)) text.replace(line, text.find(' ', line) - line, "nan");
    line = text.find('\n', line) + 1;
  }
  return text;
}

}  // namespace gauss::test
