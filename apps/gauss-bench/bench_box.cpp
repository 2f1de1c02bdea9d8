// The box scene: a port of ../shared/bench/box_scene.c (see bench_box.h).
#include "bench_box.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>

#include "gauss/engine/ply_gaussian.h"

namespace gauss::bench {

namespace fs = std::filesystem;

namespace {

constexpr int kBoxFloats = 62;  // x y z nx ny nz f_dc(3) f_rest(45) opacity scale(3) rot(4)

class BoxRng {
 public:
  double rnd() {
    s_ ^= s_ << 13;
    s_ ^= s_ >> 7;
    s_ ^= s_ << 17;
    return double(s_ >> 11) * (1.0 / 9007199254740992.0);
  }
  double uniform(double a, double b) { return a + (b - a) * rnd(); }

 private:
  std::uint64_t s_{88172645463325252ULL};
};

// One vertex's 62 floats, exactly as box_scene.c writes them.
void box_vertex(BoxRng& rng, float v[kBoxFloats]) {
  std::fill(v, v + kBoxFloats, 0.0f);
  v[0] = float(rng.uniform(-4, 4));
  v[1] = float(rng.uniform(-2.5, 2.5));
  v[2] = float(rng.uniform(-12, -3));
  for (int i = 0; i < 3; ++i) v[6 + i] = float(rng.uniform(-1.5, 1.5));
  for (int i = 0; i < 45; ++i) v[9 + i] = float(rng.uniform(-0.1, 0.1));
  v[54] = float(rng.uniform(-2, 3));
  for (int i = 0; i < 3; ++i) v[55 + i] = float(rng.uniform(-4.5, -3.0));
  double q[4], nn = 0;
  for (int i = 0; i < 4; ++i) {
    q[i] = rng.uniform(-1, 1);
    nn += q[i] * q[i];
  }
  nn = std::sqrt(nn);
  for (int i = 0; i < 4; ++i) v[58 + i] = float(q[i] / nn);
}

}  // namespace

// The PLY file box_scene.c writes for n (header + little-endian floats), byte for byte.
std::vector<std::uint8_t> box_ply_bytes(long n) {
  std::string h = "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(n) + "\n";
  for (const char* p : {"x", "y", "z", "nx", "ny", "nz"}) h += std::string("property float ") + p + "\n";
  for (int i = 0; i < 3; ++i) h += "property float f_dc_" + std::to_string(i) + "\n";
  for (int i = 0; i < 45; ++i) h += "property float f_rest_" + std::to_string(i) + "\n";
  h += "property float opacity\n";
  for (int i = 0; i < 3; ++i) h += "property float scale_" + std::to_string(i) + "\n";
  for (int i = 0; i < 4; ++i) h += "property float rot_" + std::to_string(i) + "\n";
  h += "end_header\n";
  std::vector<std::uint8_t> out(h.begin(), h.end());
  BoxRng rng;
  float v[kBoxFloats];
  for (long k = 0; k < n; ++k) {
    box_vertex(rng, v);
    const auto* b = reinterpret_cast<const std::uint8_t*>(v);  // x86/ARM: little endian
    out.insert(out.end(), b, b + sizeof v);
  }
  return out;
}

Status write_box_ply(const fs::path& path, long n) {
  std::ofstream f(path, std::ios::binary);
  const std::vector<std::uint8_t> header = box_ply_bytes(0);
  const std::string zero = "element vertex 0\n", count = "element vertex " + std::to_string(n) + "\n";
  std::string h(header.begin(), header.end());
  h.replace(h.find(zero), zero.size(), count);
  f.write(h.data(), std::streamsize(h.size()));
  BoxRng rng;
  float v[kBoxFloats];
  for (long k = 0; k < n && f; ++k) {
    box_vertex(rng, v);
    f.write(reinterpret_cast<const char*>(v), sizeof v);  // x86/ARM: little endian
  }
  f.close();
  if (!f) return Error{"cannot write the box scene (" + std::to_string(n) + " Gaussians) to " + path.string()};
  return Ok{};
}

// The same Gaussians as read_gaussian_ply would produce from that file, without the file:
// f_rest transposed to coefficient-major, quaternions kept bit for bit when within the
// loader's unit tolerance (they are: box_scene.c normalises them) else normalised.
std::vector<Gaussian> box_gaussians(long n) {
  std::vector<Gaussian> out(static_cast<std::size_t>(n));
  BoxRng rng;
  float v[kBoxFloats];
  for (auto& g : out) {
    box_vertex(rng, v);
    g.position = {v[0], v[1], v[2]};
    g.sh_dc = {v[6], v[7], v[8]};
    for (int k = 0; k < 15; ++k) g.sh_rest[std::size_t(k)] = {v[9 + k], v[9 + 15 + k], v[9 + 30 + k]};
    g.opacity_logit = v[54];
    g.log_scale = {v[55], v[56], v[57]};
    g.rotation = {v[58], v[59], v[60], v[61]};
    const double len = std::sqrt(double(v[58]) * v[58] + double(v[59]) * v[59] + double(v[60]) * v[60] +
                                 double(v[61]) * v[61]);
    if (std::abs(len - 1.0) > kQuaternionUnitTolerance) g.rotation = g.rotation / float(len);
  }
  return out;
}

// Checks the port against box_scene.c's own output for the same N: the file bytes, then the
// Gaussians (the loader's reading of the file vs box_gaussians).
bool verify_box(const fs::path& c_output) {
  std::ifstream f(c_output, std::ios::binary);
  if (!f) {
    std::fprintf(stderr, "gauss-bench render: cannot read %s\n", c_output.c_str());
    return false;
  }
  const std::vector<std::uint8_t> file((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  auto scene = parse_gaussian_ply(file, c_output.string());
  if (!scene) {
    std::fprintf(stderr, "gauss-bench render: %s\n", scene.message().c_str());
    return false;
  }
  const long n = long(scene->cloud.gaussians.size());
  if (box_ply_bytes(n) != file) {
    std::fprintf(stderr, "gauss-bench render: box scene port differs from %s (N=%ld)\n", c_output.c_str(), n);
    return false;
  }
  const std::vector<Gaussian> mine = box_gaussians(n);
  for (long k = 0; k < n; ++k) {
    const Gaussian& a = mine[std::size_t(k)];
    const Gaussian& b = scene->cloud.gaussians[std::size_t(k)];
    bool same = a.position == b.position && a.log_scale == b.log_scale && a.rotation == b.rotation &&
                a.opacity_logit == b.opacity_logit && a.sh_dc == b.sh_dc && a.sh_rest == b.sh_rest;
    if (!same) {
      std::fprintf(stderr, "gauss-bench render: box Gaussian %ld differs from the loader's reading of %s\n", k,
                   c_output.c_str());
      return false;
    }
  }
  std::printf("box scene port: %ld Gaussians bit-identical to %s (file bytes and loaded values)\n", n,
              c_output.c_str());
  return true;
}

}  // namespace gauss::bench
