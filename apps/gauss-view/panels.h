#pragma once
// Panels: gauss-view's ImGui windows over one ViewSource, drawn once per display frame
// between Window::begin_ui() and Window::record_present():
//   connection  host, state (connecting / connected / disconnected / refused / stopped),
//               bytes/s in and out, reconnects                      (panels_stream.cpp)
//   stream      M, resident / desired / pending, published Gaussian and surface epochs,
//               edits published this frame, allowance, publication mode
//   objects     the object table (resident per object refreshed kSlowRefreshS), instance
//               and class queries with rho, clear, the share of M the query got
//   timing      scrolling graphs of CPU and GPU milliseconds per pass (panels_view.cpp)
//   scene       a local scene's file, format, Gaussians, SH degree, robust and full
//               bounds, GPU memory, load time                         (panels_scene.cpp)
//   view        the bounds the default camera frames, the scene's up (and where it came
//               from) with a choice of axis, "frame (F)", the front / side / top views,
//               fly / orbit, saved viewpoints,
//               highlight, edit tints, stereo preview + IPD, speed, and every key and
//               mouse binding (help)
// A local scene (no stream) shows "local scene (no stream)" where a panel needs one.
// Below kSmallWindowWidth every panel starts collapsed (title bars stacked in two columns),
// so that a small window shows the scene; above it, the panel with nothing to show starts
// collapsed (a stream's scene panel, a local scene's objects panel) and the other takes
// the rest of the left column.
// Over the scene, bottom centre (panels_scene.cpp): a dropped file's load progress, a
// failed load's error (until dismissed or the next load), the last screenshot's path.
//
// Intents (queries, mode, highlight, tints) go straight to the ClientRuntime; what the
// frame loop needs (stereo, IPD) is read back through settings(), and what it should do to
// the camera (frame again, another up) through the take_* requests.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <glm/vec3.hpp>

#include "fly_camera.h"
#include "gauss/client/client_runtime.h"
#include "gauss/engine/scene_load.h"
#include "options.h"
#include "plot_history.h"
#include "view_source.h"

namespace gauss::view {

// "950 B", "12.3 kB", "1.25 MB", "2.10 GB" (decimal units).
std::string bytes_text(double bytes);

// What the view panel controls for the frame loop.
struct ViewSettings {
  bool stereo{false};   // side-by-side preview: two eyes, each half the window
  double ipd{0.063};    // metres
  bool highlight{true};
  bool tint_edits{false};
};

// Position and view direction: a pose stays the same view when the up changes.
struct SavedViewpoint {
  std::string name;
  glm::dvec3 position{0.0};
  glm::dvec3 forward{0.0, 0.0, 1.0};
};

class Panels {
 public:
  // resident_per_object() is O(M) and the object table is copied under the state lock:
  // both are refreshed at most this often (seconds).
  static constexpr double kSlowRefreshS = 0.25;
  // Byte rates are averaged over at least this long (seconds).
  static constexpr double kRateWindowS = 0.5;

  Panels(const ViewOptions& opts, ViewSource& source);

  // This frame's CPU figures (`interval_ms`: since the previous frame) and the GPU
  // figures of frames that finished since the last call.
  void add_frame(const client::DisplayFrameStats& stats, double interval_ms);
  void add_gpu(const client::GpuFrameStats& gpu);
  // Below this window width (pixels) every panel starts collapsed.
  static constexpr std::uint32_t kSmallWindowWidth = 1000;
  // A screenshot's path stays on screen this long (seconds).
  static constexpr double kNoticeS = 8.0;

  // Another source (a dropped file replaced the scene): the panels read it from now on.
  void set_source(ViewSource& source);
  // The load in progress since `now_s` (nullptr: none); shown with its progress until cleared.
  void set_loading(const SceneLoadJob* job, double now_s) {
    loading_ = job;
    loading_since_s_ = now_s;
  }
  // A failed load's message: shown until dismissed or clear_error() (the next load).
  void show_error(std::string message) { error_ = std::move(message); }
  void clear_error() { error_.clear(); }
  // A transient line (a screenshot's path), shown for kNoticeS from `now_s`.
  void show_notice(std::string message, double now_s);

  // Draws every panel for a `width` x `height` window (first-use placement); `now_s` is
  // a steady clock in seconds; `orbit`: the camera is in orbit mode. May move `camera`
  // (viewpoints, speed).
  void draw(FlyCamera& camera, bool orbit, std::uint32_t width, std::uint32_t height, double now_s);

  const ViewSettings& settings() const noexcept { return settings_; }
  // Fly or orbit chosen in the view panel since the last call (true: orbit).
  std::optional<bool> take_mode_request() { return std::exchange(mode_request_, std::nullopt); }
  // A view panel button that frames the scene (front, side, top) pressed since the last call.
  std::optional<ViewPreset> take_view_request() { return std::exchange(view_request_, std::nullopt); }
  // An up chosen in the view panel since the last call.
  std::optional<glm::dvec3> take_up_request() { return std::exchange(up_request_, std::nullopt); }

 private:
  struct ObjectRow {
    std::int32_t id{0};
    std::string label;
    std::uint32_t members{0};
    std::uint32_t resident{0};
  };
  struct Rates {
    double at_s{-1.0};
    std::uint64_t in{0}, out{0};
    double in_per_s{0.0}, out_per_s{0.0};
    double net_cpu_ms{0.0}, net_cpu_share{0.0};  // the network thread's CPU time, and its share of one core
  };

  void place(float x, float y, float w, float h, bool collapsed) const;
  void draw_connection(double now_s);
  void draw_stream();
  void draw_objects(double now_s);
  void draw_timing();
  void draw_view(FlyCamera& camera, bool orbit);
  void draw_framing(FlyCamera& camera);
  void draw_scene();
  void draw_notices(std::uint32_t width, std::uint32_t height, double now_s);
  void refresh_objects(double now_s);

  ViewSource* source_;
  client::ClientRuntime* rt_;  // nullptr: local scene
  ViewSettings settings_;
  bool small_window_{false};   // first-use layout: start the secondary panels collapsed

  std::optional<client::DisplayFrameStats> last_;
  PlotHistory frame_ms_, cpu_ms_;
  PlotHistory gpu_mesh_, gpu_preprocess_, gpu_sorts_, gpu_emit_, gpu_blend_, gpu_total_;
  std::uint32_t gpu_visible_{0};

  Rates rates_;
  double objects_at_s_{-1.0};
  std::vector<ObjectRow> objects_;
  std::vector<std::string> classes_;  // distinct labels, sorted
  int class_index_{0};
  float rho_{0.5f};
  std::vector<ObjectId> targets_;
  std::uint64_t target_resident_{0};
  std::string last_query_;

  const SceneLoadJob* loading_{nullptr};
  double loading_since_s_{0.0};
  std::string error_;
  std::string notice_;
  double notice_until_s_{-1.0};

  std::optional<ViewPreset> view_request_;
  std::optional<bool> mode_request_;
  std::optional<glm::dvec3> up_request_;
  std::vector<SavedViewpoint> viewpoints_;
  int next_viewpoint_{1};
};

}  // namespace gauss::view
