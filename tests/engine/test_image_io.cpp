// PNG / JPEG I/O (stb; 16-bit PNG writing with zlib): RGBA8 round trip, 16-bit depth round
// trip, JPEG colour, and the failure messages.
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "gauss/engine/image_io.h"
#include "test_data.h"

namespace gauss {
namespace {

ImageRGBA8 make_image(std::uint32_t w, std::uint32_t h) {
  ImageRGBA8 img;
  img.width = w;
  img.height = h;
  img.pixels.resize(std::size_t(w) * h * 4);
  for (std::size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = std::uint8_t((i * 37 + i / 7) & 0xFF);
  return img;
}

TEST(ImageIo, Rgba8RoundTripIsExact) {
  const auto path = test::output_dir() / "image_io_roundtrip.png";
  const ImageRGBA8 img = make_image(17, 5);  // odd width: row stride must be right
  ASSERT_TRUE(write_png(path, img).ok());
  auto back = read_png_rgba8(path);
  ASSERT_TRUE(back.ok()) << back.message();
  EXPECT_EQ(back->width, 17u);
  EXPECT_EQ(back->height, 5u);
  EXPECT_EQ(back->pixels, img.pixels);
  // An 8-bit PNG is not a depth image.
  auto as_depth = read_png_u16(path);
  ASSERT_FALSE(as_depth.ok());
  EXPECT_NE(as_depth.message().find("expected a 16-bit PNG, found 8-bit samples"), std::string::npos)
      << as_depth.message();
}

TEST(ImageIo, WriteRejectsInconsistentImagesAndBadPaths) {
  ImageRGBA8 img = make_image(4, 4);
  img.pixels.pop_back();
  auto st = write_png(test::output_dir() / "bad.png", img);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("pixel buffer size 63 does not match 4x4 RGBA8"), std::string::npos) << st.message();
  ImageRGBA8 empty;
  st = write_png(test::output_dir() / "empty.png", empty);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("cannot write an empty image"), std::string::npos);
  st = write_png(test::output_dir() / "no_such_dir" / "x.png", make_image(2, 2));
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("no_such_dir"), std::string::npos) << st.message();
}

TEST(ImageIo, ReadFailuresNameTheFile) {
  auto missing = read_png_rgba8(test::output_dir() / "does_not_exist.png");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("does_not_exist.png: cannot read PNG"), std::string::npos) << missing.message();
  auto missing16 = read_png_u16(test::output_dir() / "does_not_exist.png");
  ASSERT_FALSE(missing16.ok());
  EXPECT_NE(missing16.message().find("does_not_exist.png"), std::string::npos);

  const auto junk = test::output_dir() / "not_a_png.png";
  std::ofstream(junk, std::ios::binary) << "this is not a PNG file at all";
  auto r = read_png_rgba8(junk);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.message().find("not_a_png.png: cannot read PNG"), std::string::npos) << r.message();

  // A truncated PNG: the first 40 bytes of a valid file.
  const auto good = test::output_dir() / "image_io_trunc_src.png";
  ASSERT_TRUE(write_png(good, make_image(32, 32)).ok());
  std::ifstream in(good, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto cut = test::output_dir() / "image_io_truncated.png";
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, 40);
  auto t = read_png_rgba8(cut);
  ASSERT_FALSE(t.ok());
  EXPECT_NE(t.message().find("image_io_truncated.png"), std::string::npos) << t.message();
}

TEST(ImageIo, SixteenBitRoundTripKeepsEverySample) {
  ImageU16 img;
  img.width = 13;  // odd width: row stride must be right
  img.height = 7;
  for (std::uint32_t k = 0; k < img.width * img.height; ++k) img.pixels.push_back(std::uint16_t(k * 719 + (k << 11)));
  img.pixels[0] = 0;
  img.pixels[1] = 65535;
  const auto path = test::output_dir() / "image_io_u16.png";
  ASSERT_TRUE(write_png_u16(path, img).ok());
  auto back = read_png_u16(path);
  ASSERT_TRUE(back.ok()) << back.message();
  EXPECT_EQ(back->width, 13u);
  EXPECT_EQ(back->height, 7u);
  EXPECT_EQ(back->pixels, img.pixels);
  img.pixels.pop_back();
  auto st = write_png_u16(path, img);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("sample count 90 does not match 13x7"), std::string::npos) << st.message();
}

TEST(ImageIo, JpegIsReadByContentNotAsPng) {
  ImageRGBA8 img;
  img.width = 24;
  img.height = 16;
  for (std::uint32_t k = 0; k < img.width * img.height; ++k) img.pixels.insert(img.pixels.end(), {40, 160, 220, 255});
  const auto path = test::output_dir() / "image_io_colour.png";  // a JPEG under a PNG name
  ASSERT_TRUE(write_jpeg(path, img, 95).ok());
  auto back = read_image_rgba8(path);
  ASSERT_TRUE(back.ok()) << back.message();
  ASSERT_EQ(back->width, 24u);
  for (std::size_t k = 0; k < back->pixels.size(); ++k) EXPECT_NEAR(back->pixels[k], img.pixels[k], 3) << k;
  auto as_png = read_png_rgba8(path);
  ASSERT_FALSE(as_png.ok());
  EXPECT_NE(as_png.message().find("cannot read PNG: the file is a JPEG"), std::string::npos) << as_png.message();
  const auto junk = test::output_dir() / "image_io_junk.jpg";
  std::ofstream(junk, std::ios::binary) << "neither";
  auto j = read_image_rgba8(junk);
  ASSERT_FALSE(j.ok());
  EXPECT_NE(j.message().find("image_io_junk.jpg: cannot read image: neither a PNG nor a JPEG"), std::string::npos)
      << j.message();
  EXPECT_FALSE(write_jpeg(path, img, 0).ok());
}

TEST(ImageIoData, SixteenBitDepthFrame) {
  GAUSS_REQUIRE_DATA(path, "rgbd/sun3d_studyroom/seq-01/frame-000000.depth.png");
  auto d = read_png_u16(path);
  ASSERT_TRUE(d.ok()) << d.message();
  EXPECT_EQ(d->width, 640u);
  EXPECT_EQ(d->height, 480u);
  ASSERT_EQ(d->pixels.size(), 640u * 480u);
  // Kinect depth in millimetres: a room is mostly 0.4 m to 10 m, with 0 for missing depth.
  std::size_t valid = 0, above_255 = 0;
  for (std::uint16_t v : d->pixels) {
    if (v == 0) continue;
    ++valid;
    above_255 += v > 255;
    EXPECT_LT(v, 10000);
  }
  EXPECT_GT(valid, d->pixels.size() / 2);
  EXPECT_GT(above_255, valid / 2) << "samples must keep their 16 bits";
  // The colour frame of the same view reads as RGBA8 at the same size.
  GAUSS_REQUIRE_DATA(color_path, "rgbd/sun3d_studyroom/seq-01/frame-000000.color.png");
  auto c = read_png_rgba8(color_path);
  ASSERT_TRUE(c.ok()) << c.message();
  EXPECT_EQ(c->width, 640u);
  EXPECT_EQ(c->height, 480u);
  auto c16 = read_png_u16(color_path);
  EXPECT_FALSE(c16.ok());
}

}  // namespace
}  // namespace gauss
