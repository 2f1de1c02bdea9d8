#pragma once
// What every program in apps/ shares on the command line, so they all behave alike:
//   - options through CLI11, `--help` everywhere, defaults shown in the help;
//   - one error style: CLI11's message naming the option, then "Run with --help for more
//     information.", exit status 2 (CLI11's own codes are >= 100; 2 is the Unix usage
//     convention our scripts and tests rely on);
//   - validators with readable messages (bounds, WxH sizes);
//   - one status line on stderr for work that takes longer than about a second
//     (status_line.h, included here; a file that needs only that includes it alone: CLI11
//     costs every file that sees it about 4 s of compile time).
// Header only: each program is one executable, nothing here is worth a library.
#include <cstdint>
#include <limits>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>

#include <CLI/CLI.hpp>

#include "gauss/engine/scene_up.h"
#include "status_line.h"

namespace gauss::apps {

// Exit status of a command line CLI11 refused (unknown option, bad value, missing one).
inline constexpr int kUsageError = 2;

// Settings every program's CLI::App gets: defaults printed in --help, a wider option
// column (our option names with their types do not fit CLI11's 30 characters).
inline void configure(CLI::App& app) {
  app.option_defaults()->always_capture_default();
  app.get_formatter()->column_width(36);
}

// Parses argv into `app`. Returns the exit status when the program should stop now:
// 0 after --help (printed on stdout), kUsageError after a refused command line (CLI11's
// message on stderr); std::nullopt when the program should go on.
inline std::optional<int> parse(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : kUsageError;
  }
  return std::nullopt;
}

// Value checks with readable messages ("Value -1 is below 0", "Value 2 is not in 0..1").
// CLI::Range prints doubles as "0.000000" and the type's maximum in full when only a lower
// bound is wanted, and CLI11 2.1 converts "-3" to a huge unsigned: both are handled here.
namespace detail {
template <class T>
std::string text_of(T v) {
  std::ostringstream s;
  s << v;
  return s.str();
}
// Converts `in`; an empty string when it is a number of type T in [lo, hi], else why not.
template <class T>
std::string check_bounds(const std::string& in, T lo, T hi, const std::string& bounds) {
  T v{};
  if (!CLI::detail::lexical_cast(in, v)) return "Value " + in + " is not a number";
  if constexpr (std::is_unsigned_v<T>)
    if (in.find('-') != std::string::npos) return "Value " + in + " is not " + bounds;
  return v < lo || v > hi ? "Value " + in + " is not " + bounds : std::string{};
}
}  // namespace detail

// Accepts a value of type T that is at least `lo`.
template <class T>
CLI::Validator at_least(T lo) {
  const std::string bounds = ">= " + detail::text_of(lo);
  return CLI::Validator(
      [lo, bounds](std::string& in) { return detail::check_bounds(in, lo, std::numeric_limits<T>::max(), bounds); },
      ">=" + detail::text_of(lo));
}

// Accepts a value of type T in [lo, hi].
template <class T>
CLI::Validator in_range(T lo, T hi) {
  const std::string bounds = "in " + detail::text_of(lo) + ".." + detail::text_of(hi);
  return CLI::Validator([lo, hi, bounds](std::string& in) { return detail::check_bounds(in, lo, hi, bounds); },
                        detail::text_of(lo) + ".." + detail::text_of(hi));
}

// "WxH" with both in [1, 16384] (an image size), or std::nullopt.
inline std::optional<std::pair<std::uint32_t, std::uint32_t>> parse_size(const std::string& s) {
  const auto x = s.find('x');
  if (x == std::string::npos) return std::nullopt;
  std::uint32_t w = 0, h = 0;
  if (!CLI::detail::lexical_cast(s.substr(0, x), w) || !CLI::detail::lexical_cast(s.substr(x + 1), h)) return std::nullopt;
  if (w < 1 || h < 1 || w > 16384 || h > 16384) return std::nullopt;
  return std::pair{w, h};
}

// An "on|off" option for a bool that has a default either way.
inline CLI::Option* add_on_off(CLI::App& app, const std::string& name, bool& value, const std::string& what) {
  return app
      .add_option_function<std::string>(name, [&value](const std::string& v) { value = v == "on"; },
                                        what + " (on|off; default " + (value ? "on" : "off") + ")")
      ->check(CLI::IsMember({"on", "off"}));
}

// An "--up AXIS" option (+x -x +y -y +z -z, parse_up_axis) into `value`, unset when not given.
inline CLI::Option* add_up_option(CLI::App& app, std::optional<glm::dvec3>& value, const std::string& what) {
  return app
      .add_option_function<std::string>("--up", [&value](const std::string& v) { value = *parse_up_axis(v); }, what)
      ->check(CLI::Validator(
          [](std::string& in) {
            auto r = parse_up_axis(in);
            return r ? std::string() : r.message();
          },
          ""))
      ->type_name("AXIS");
}

// Validator for parse_size.
inline CLI::Validator image_size() {
  return CLI::Validator(
      [](std::string& in) -> std::string {
        return parse_size(in) ? std::string{} : "Value " + in + " is not WxH (each in 1..16384)";
      },
      "WxH");
}

}  // namespace gauss::apps
