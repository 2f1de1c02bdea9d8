#pragma once
// The report's images: views side by side (GT | PC | HS | difference ...) in one PNG, and
// FLIP error maps drawn in the magma colour map the FLIP authors use (0 black .. 1 pale).
#include <filesystem>
#include <string>
#include <vector>

#include "gauss/engine/image_io.h"
#include "gauss/engine/result.h"

namespace gauss::eval_app {

// A FLIP map (values in [0, 1], row-major) as an image.
ImageRGBA8 flip_image(const std::vector<float>& map, std::uint32_t width, std::uint32_t height);

// Where the report's PNGs go; disabled (every call a no-op) with --no-images.
class PanelWriter {
 public:
  PanelWriter(std::filesystem::path dir, bool enabled) : dir_(std::move(dir)), enabled_(enabled) {}
  bool enabled() const noexcept { return enabled_; }
  // Writes the images (all of one size) side by side, 4 px apart, as DIR/<name>.png.
  Status write(const std::string& name, const std::vector<const ImageRGBA8*>& images) const;

 private:
  std::filesystem::path dir_;
  bool enabled_;
};

}  // namespace gauss::eval_app
