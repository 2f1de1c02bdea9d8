// SOG meta.json parsing (splat_sog_meta.h). nlohmann::json runs without exceptions here
// (parse with allow_exceptions = false; every access is type-checked first).
#include "io/splat_sog_meta.h"

#include <cmath>
#include <limits>
#include <string>

#include <nlohmann/json.hpp>

#include "io/ply_core.h"  // ply::format_double

namespace gauss::io {
namespace {

using nlohmann::json;

constexpr std::size_t kCodebookSize = 256;
constexpr std::size_t kMaxNameBytes = 1024;

class MetaReader {
 public:
  explicit MetaReader(std::string_view what) : what_(what) {}

  Error fail(const std::string& path, const std::string& msg) const {
    return Error{what_ + ": " + (path.empty() ? msg : "'" + path + "' " + msg)};
  }

  // The member `key` of object `j` (at `path`), or nullptr when absent.
  static const json* member(const json& j, const char* key) {
    const auto it = j.find(key);
    return it == j.end() ? nullptr : &*it;
  }

  Expected<const json*> object(const json& j, const std::string& path, const char* key) const {
    const json* m = member(j, key);
    const std::string p = join(path, key);
    if (!m) return fail(p, "is missing");
    if (!m->is_object()) return fail(p, std::string("must be an object, not ") + m->type_name());
    return m;
  }

  Status number(const json& j, const std::string& path, double& out) const {
    if (!j.is_number()) return fail(path, std::string("must be a number, not ") + j.type_name());
    const double v = j.get<double>();
    if (!std::isfinite(v) || std::abs(v) > double(std::numeric_limits<float>::max()))
      return fail(path, "is " + ply::format_double(v) + ", outside the float range");
    out = v;
    return Ok{};
  }

  Status count(const json& j, const std::string& path, std::size_t limit, std::size_t& out) const {
    if (!j.is_number_integer()) return fail(path, std::string("must be an integer, not ") + j.type_name());
    if (j.is_number_unsigned()) {
      const auto v = j.get<std::uint64_t>();
      if (v > limit) return fail(path, "is " + std::to_string(v) + ", more than the " + std::to_string(limit) + " this reader accepts");
      out = static_cast<std::size_t>(v);
      return Ok{};
    }
    const auto v = j.get<std::int64_t>();
    if (v < 0) return fail(path, "is " + std::to_string(v) + "; it must not be negative");
    if (static_cast<std::uint64_t>(v) > limit)
      return fail(path, "is " + std::to_string(v) + ", more than the " + std::to_string(limit) + " this reader accepts");
    out = static_cast<std::size_t>(v);
    return Ok{};
  }

  // `n` numbers in the array member `key`.
  Status numbers(const json& j, const std::string& path, const char* key, std::size_t n, double* out) const {
    const json* m = member(j, key);
    const std::string p = join(path, key);
    if (!m) return fail(p, "is missing");
    if (!m->is_array() || m->size() != n)
      return fail(p, "must be an array of " + std::to_string(n) + " numbers");
    for (std::size_t k = 0; k < n; ++k)
      if (Status st = number((*m)[k], p + "[" + std::to_string(k) + "]", out[k]); !st) return st;
    return Ok{};
  }

  // The array member "files" of `j` with exactly `n` image names.
  Status files(const json& j, const std::string& path, std::size_t n, std::string* out[]) const {
    const json* m = member(j, "files");
    const std::string p = join(path, "files");
    if (!m) return fail(p, "is missing");
    if (!m->is_array() || m->size() < n)
      return fail(p, "must be an array of " + std::to_string(n) + " file name" + (n > 1 ? "s" : ""));
    for (std::size_t k = 0; k < n; ++k) {
      const json& s = (*m)[k];
      const std::string pk = p + "[" + std::to_string(k) + "]";
      if (!s.is_string()) return fail(pk, std::string("must be a string, not ") + s.type_name());
      const std::string& name = s.get_ref<const std::string&>();
      if (Status st = safe_name(name, pk); !st) return st;
      *out[k] = name;
    }
    return Ok{};
  }

  Expected<SogCodebook> codebook(const json& j, const std::string& path) const {
    const json* m = member(j, "codebook");
    const std::string p = join(path, "codebook");
    if (!m) return fail(p, "is missing (version 2 quantises through codebooks)");
    if (!m->is_array() || m->empty() || m->size() > kCodebookSize)
      return fail(p, "must be an array of up to 256 numbers");
    SogCodebook cb;
    cb.values.assign(m->size(), 0.0f);
    cb.valid.assign(m->size(), 0);
    for (std::size_t k = 0; k < m->size(); ++k) {
      const json& v = (*m)[k];
      if (v.is_null()) continue;  // an empty cluster; an error only if a pixel uses it
      double d = 0.0;
      if (Status st = number(v, p + "[" + std::to_string(k) + "]", d); !st) return st.error();
      cb.values[k] = static_cast<float>(d);
      cb.valid[k] = 1;
    }
    // The PlayCanvas engine's patch for a null first entry (see the header).
    if (cb.values.size() == kCodebookSize && !cb.valid[0] && cb.valid[1] && cb.valid[255]) {
      const double patched = double(cb.values[1]) + (double(cb.values[1]) - double(cb.values[255])) / 255.0;
      if (std::abs(patched) <= double(std::numeric_limits<float>::max())) {
        cb.values[0] = static_cast<float>(patched);
        cb.valid[0] = 1;
      }
    }
    return cb;
  }

 private:
  static std::string join(const std::string& path, const char* key) { return path.empty() ? key : path + "." + key; }

  // Image names stay inside the folder or archive: relative, no "..", no backslashes or NULs.
  Status safe_name(const std::string& name, const std::string& path) const {
    if (name.empty()) return fail(path, "is an empty file name");
    if (name.size() > kMaxNameBytes) return fail(path, "is a file name longer than " + std::to_string(kMaxNameBytes) + " bytes");
    if (name.front() == '/' || name.find('\\') != std::string::npos || name.find('\0') != std::string::npos ||
        name.find(':') != std::string::npos)
      return fail(path, "'" + name + "' must be a plain relative name (no leading '/', '\\', ':' or NUL)");
    std::size_t start = 0;
    while (start <= name.size()) {
      const std::size_t end = std::min(name.find('/', start), name.size());
      if (name.compare(start, end - start, "..") == 0)
        return fail(path, "'" + name + "' must not leave its folder ('..')");
      start = end + 1;
    }
    return Ok{};
  }

  std::string what_;
};

Status parse_v2(const MetaReader& r, const json& j, SogMeta& m) {
  const json* count = MetaReader::member(j, "count");
  if (!count) return r.fail("count", "is missing");
  if (Status st = r.count(*count, "count", kMaxSogGaussians, m.count); !st) return st;

  auto scales = r.object(j, "", "scales");
  if (!scales) return scales.error();
  std::string* scale_files[] = {&m.scales};
  if (Status st = r.files(**scales, "scales", 1, scale_files); !st) return st;
  auto scb = r.codebook(**scales, "scales");
  if (!scb) return scb.error();
  m.scales_codebook = std::move(*scb);

  auto sh0 = r.object(j, "", "sh0");
  if (!sh0) return sh0.error();
  std::string* sh0_files[] = {&m.sh0};
  if (Status st = r.files(**sh0, "sh0", 1, sh0_files); !st) return st;
  auto ccb = r.codebook(**sh0, "sh0");
  if (!ccb) return ccb.error();
  m.sh0_codebook = std::move(*ccb);

  const json* shn = MetaReader::member(j, "shN");
  if (!shn || shn->is_null()) return Ok{};
  if (!shn->is_object()) return r.fail("shN", std::string("must be an object, not ") + shn->type_name());
  m.has_shn = true;
  const json* bands = MetaReader::member(*shn, "bands");
  std::size_t b = 0;
  if (!bands) return r.fail("shN.bands", "is missing");
  if (Status st = r.count(*bands, "shN.bands", 3, b); !st) return st;
  if (b < 1) return r.fail("shN.bands", "is 0; expected 1..3 (omit shN for SH degree 0)");
  m.shn_bands = static_cast<int>(b);
  const json* palette = MetaReader::member(*shn, "count");
  if (!palette) return r.fail("shN.count", "is missing");
  if (Status st = r.count(*palette, "shN.count", 65536, m.shn_count); !st) return st;
  if (m.shn_count < 1) return r.fail("shN.count", "is 0; a palette needs at least one entry");
  std::string* shn_files[] = {&m.shn_centroids, &m.shn_labels};
  if (Status st = r.files(*shn, "shN", 2, shn_files); !st) return st;
  auto ncb = r.codebook(*shn, "shN");
  if (!ncb) return ncb.error();
  m.shn_codebook = std::move(*ncb);
  return Ok{};
}

Status parse_v1(const MetaReader& r, const json& j, SogMeta& m) {
  auto means = r.object(j, "", "means");
  if (!means) return means.error();
  const json* shape = MetaReader::member(**means, "shape");
  if (!shape) return r.fail("means.shape", "is missing (a version 1 meta.json gives the count as means.shape[0])");
  if (!shape->is_array() || shape->empty())
    return r.fail("means.shape", "must be an array whose first entry is the Gaussian count");
  if (Status st = r.count((*shape)[0], "means.shape[0]", kMaxSogGaussians, m.count); !st) return st;

  auto scales = r.object(j, "", "scales");
  if (!scales) return scales.error();
  std::string* scale_files[] = {&m.scales};
  if (Status st = r.files(**scales, "scales", 1, scale_files); !st) return st;
  if (Status st = r.numbers(**scales, "scales", "mins", 3, m.scales_min.data()); !st) return st;
  if (Status st = r.numbers(**scales, "scales", "maxs", 3, m.scales_max.data()); !st) return st;

  auto sh0 = r.object(j, "", "sh0");
  if (!sh0) return sh0.error();
  std::string* sh0_files[] = {&m.sh0};
  if (Status st = r.files(**sh0, "sh0", 1, sh0_files); !st) return st;
  if (Status st = r.numbers(**sh0, "sh0", "mins", 4, m.sh0_min.data()); !st) return st;
  if (Status st = r.numbers(**sh0, "sh0", "maxs", 4, m.sh0_max.data()); !st) return st;

  const json* shn = MetaReader::member(j, "shN");
  if (!shn || shn->is_null()) return Ok{};
  if (!shn->is_object()) return r.fail("shN", std::string("must be an object, not ") + shn->type_name());
  m.has_shn = true;
  const json* lo = MetaReader::member(*shn, "mins");
  const json* hi = MetaReader::member(*shn, "maxs");
  if (!lo || !hi) return r.fail(lo ? "shN.maxs" : "shN.mins", "is missing");
  if (Status st = r.number(*lo, "shN.mins", m.shn_min); !st) return st;
  if (Status st = r.number(*hi, "shN.maxs", m.shn_max); !st) return st;
  std::string* shn_files[] = {&m.shn_centroids, &m.shn_labels};
  return r.files(*shn, "shN", 2, shn_files);
}

}  // namespace

Expected<SogMeta> parse_sog_meta(std::span<const std::uint8_t> text, std::string_view what) {
  const MetaReader r(what);
  const json j = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) return r.fail("", "is not valid JSON");
  if (!j.is_object()) return r.fail("", std::string("must hold a JSON object, not ") + j.type_name());

  SogMeta m;
  const json* version = MetaReader::member(j, "version");
  if (!version) {
    m.version = 1;  // the legacy layout has no version field
  } else {
    std::size_t v = 0;
    if (Status st = r.count(*version, "version", 1u << 20, v); !st) return st.error();
    if (v != 2)
      return r.fail("version", "is " + std::to_string(v) +
                                   "; this reader knows version 2 and the unversioned legacy layout (version 1)");
    m.version = 2;
  }

  auto means = r.object(j, "", "means");
  if (!means) return means.error();
  if (Status st = r.numbers(**means, "means", "mins", 3, m.means_min.data()); !st) return st.error();
  if (Status st = r.numbers(**means, "means", "maxs", 3, m.means_max.data()); !st) return st.error();
  // Positions are sign(n) (exp(|n|) - 1): beyond |n| = 88 that overflows a float.
  for (int a = 0; a < 3; ++a)
    for (double v : {m.means_min[static_cast<std::size_t>(a)], m.means_max[static_cast<std::size_t>(a)]})
      if (std::abs(v) > 88.0)
        return r.fail("means", "range " + ply::format_double(v) +
                                   " is beyond +-88 (log domain): the decoded position would overflow a float");
  std::string* mean_files[] = {&m.means_l, &m.means_u};
  if (Status st = r.files(**means, "means", 2, mean_files); !st) return st.error();
  auto quats = r.object(j, "", "quats");
  if (!quats) return quats.error();
  std::string* quat_files[] = {&m.quats};
  if (Status st = r.files(**quats, "quats", 1, quat_files); !st) return st.error();

  if (Status st = m.version == 2 ? parse_v2(r, j, m) : parse_v1(r, j, m); !st) return st.error();
  return m;
}

}  // namespace gauss::io
