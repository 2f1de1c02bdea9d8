#pragma once
// The benchmark scene "box" of ../shared/bench/box_scene.c, ported draw for draw (same
// xorshift, same order of draws): N random SH3 Gaussians in x[-4,4] y[-2.5,2.5] z[-12,-3],
// in front of a camera at the origin looking down -z. The scene for N is the first N
// Gaussians of the scene for any larger N.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "gauss/engine/gaussian.h"
#include "gauss/engine/result.h"

namespace gauss::bench {

// The PLY file box_scene.c writes for n (header + little-endian floats), byte for byte.
std::vector<std::uint8_t> box_ply_bytes(long n);

// Writes that file to `path` as it is generated (4M Gaussians are about 1 GB: never held
// in memory). Fails naming the path when it cannot be written.
Status write_box_ply(const std::filesystem::path& path, long n);

// The same Gaussians as read_gaussian_ply would produce from that file, without the file.
std::vector<Gaussian> box_gaussians(long n);

// Checks the port against box_scene.c's own output for the same N: the file bytes, then the
// Gaussians (the loader's reading of the file vs box_gaussians). Prints the outcome; false
// (with the reason on stderr) when they differ.
bool verify_box(const std::filesystem::path& c_output);

}  // namespace gauss::bench
