#include "report.h"

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

namespace gauss::eval_app {

namespace {

// A metric cell: the number with `digits` decimals, "∞" for identical images, "n/a" for
// anything else (no pixel in the mask, an error).
std::string cell(const Json& j, int digits) {
  if (j.is_number()) {
    char b[64];
    std::snprintf(b, sizeof b, "%.*f", digits, j.get<double>());
    return b;
  }
  if (j.is_string() && j.get<std::string>() == "inf") return "∞";
  return "n/a";
}

std::string metric(const Json& scores, const char* key, int digits) {
  return scores.is_object() && scores.contains(key) ? cell(scores[key], digits) : "n/a";
}

std::string integer(const Json& j) { return j.is_number() ? std::to_string(j.get<std::int64_t>()) : "n/a"; }

std::string percent(const Json& j) {
  if (!j.is_number()) return "n/a";
  char b[32];
  std::snprintf(b, sizeof b, "%.1f %%", 100.0 * j.get<double>());
  return b;
}

// A fidelity row's cells from GT-PC PSNR to "HS ≠ sent" (the deterministic and the
// realtime tables share them).
std::string fidelity_cells(const Json& c) {
  std::ostringstream md;
  md << metric(c["gt_pc"], "psnr_db", 2) << " | " << metric(c["pc_hs"], "psnr_db", 2) << " | "
     << metric(c["pc_hs"], "ssim", 3) << " | " << metric(c["pc_hs"], "flip", 3) << " | "
     << metric(c["pc_hs_all"], "psnr_db", 2) << " | "
     << metric(c["gt_hs"], "psnr_db", 2) << " | " << metric(c["gt_hs"], "ssim", 3) << " | "
     << metric(c["gt_hs"], "flip", 3) << " | " << percent(c["coverage"]["pc"]) << " / " << percent(c["coverage"]["hs"])
     << " / " << percent(c["coverage"]["both"]) << " | " << integer(c["resident"]) << " | "
     << integer(c["hs_vs_sent"]["differing_pixels"]);
  return md.str();
}

// --lod both: each fidelity camera without the LoD cut → with it.
void lod_comparison_table(std::ostream& md, const Json& report) {
  bool any = false;
  for (const Json& s : report["scenes"])
    if (s.contains("fidelity"))
      for (const Json& c : s["fidelity"]["cameras"]) any = any || c.contains("without_lod");
  if (!any) return;
  md << "### Level of detail: leaves only → LoD cut\n\n"
     << "The same cameras on a second connection whose host sends only its best M Gaussians (leaves only), "
        "against the run above, where what the budget cannot hold in detail is a coarse cut through the merge "
        "hierarchy (*interior*: coarse records among the M). HS cover: the share of the view the sent set "
        "covers; PC-HS over PC's pixels counts its holes.\n\n"
     << "| scene | cam | HS cover (PC) | GT-HS PSNR | PC-HS PSNR, both cover | PC-HS PSNR, PC's px | interior |\n"
     << "|---|---|---|---|---|---|---|\n";
  auto pair = [](const Json& a, const Json& b, const char* field) {
    return metric(a[field], "psnr_db", 2) + " → " + metric(b[field], "psnr_db", 2);
  };
  for (const Json& s : report["scenes"]) {
    if (!s.contains("fidelity")) continue;
    for (const Json& c : s["fidelity"]["cameras"]) {
      if (!c.contains("without_lod")) continue;
      const Json& w = c["without_lod"];
      md << "| " << s["name"].get<std::string>() << " | " << c["camera"].get<int>() << " | "
         << percent(w["coverage"]["hs"]) << " → " << percent(c["coverage"]["hs"]) << " (" << percent(c["coverage"]["pc"])
         << ") | " << pair(w, c, "gt_hs") << " | " << pair(w, c, "pc_hs") << " | " << pair(w, c, "pc_hs_all") << " | "
         << integer(c["lod_interior"]) << " |\n";
    }
  }
  md << "\n";
}

void fidelity_section(std::ostream& md, const Json& report, bool images) {
  md << "## Fidelity: GT → PC → HS\n\n"
     << "GT: the analytic room ray-cast (exact colour and depth); a scene file has none (n/a)"
     << (report["definitions"].contains("capture ground truth")
             ? "; an RGB-D capture: its own frames at its cameras (see capture ground truth below)"
             : "")
     << ". PC: the host's render of the full float "
        "scene with the client's renderer. HS: the client's frame once it converged at the camera "
        "(at M = " << integer(report["config"]["budget"]) << ", quantised, published " 
     << report["config"]["mode"].get<std::string>() << "ly). *HS ≠ sent*: pixels where HS differs from the "
        "host's own render of the very set it sent, loaded in the client's slot order (must be 0). "
        "Conv.: virtual seconds from the move to the camera until the client's published set equals "
        "the host's sent set for good.\n\n";
  md << "| scene | cam | GT-PC PSNR | PC-HS PSNR | PC-HS SSIM | PC-HS FLIP | PC-HS PSNR, PC's px | GT-HS PSNR | GT-HS SSIM "
        "| GT-HS FLIP "
        "| cover PC / HS / both | resident | HS ≠ sent | conv. s |\n"
     << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Json& s : report["scenes"]) {
    if (!s.contains("fidelity")) continue;
    for (const Json& c : s["fidelity"]["cameras"]) {
      md << "| " << s["name"].get<std::string>() << " | " << c["camera"].get<int>() << " | " << fidelity_cells(c)
         << " | " << cell(c["settle"]["converged_s"], 2) << " |\n";
    }
  }
  md << "\n";
  lod_comparison_table(md, report);
  if (!images) return;
  md << "Each panel: GT | PC | HS | FLIP(PC, HS) (magma: black = no error); without ground truth PC | HS | "
        "FLIP(PC, HS).\n\n";
  for (const Json& s : report["scenes"]) {
    if (!s.contains("fidelity")) continue;
    for (const Json& c : s["fidelity"]["cameras"]) {
      const std::string f = s["name"].get<std::string>() + "_cam" + std::to_string(c["camera"].get<int>()) + ".png";
      md << "![" << f << "](" << f << ")\n";
    }
  }
  md << "\n";
}

void semantic_section(std::ostream& md, const Json& report, bool images) {
  bool any = false;  // --no-semantic, or scenes without objects: no table to show
  for (const Json& s : report["scenes"]) any = any || (s.contains("semantic") && !s["semantic"].empty());
  if (!any) return;
  md << "## Semantic reallocation of a fixed budget\n\n"
     << "A query reserves M_obj = min(|G_obj|, ⌊ρM⌋) of the M slots for the target's appearance Gaussians "
        "(carriers excluded) and gives the rest to the background; N_obj counts the client's resident "
        "Gaussians on the target after convergence. *Expected* is M_obj / M. Object PSNR is GT-HS over "
        "the target's pixels (the ground truth's object ids), without → with the query; GT-PC over the "
        "same pixels is the ceiling. PC-HS is the same over the host's full render (for a scene file, "
        "which has no ground truth, the target's pixels are those its Gaussians alone cover).\n\n";
  md << "| scene | object (query) | model | M | ρ | \\|G_obj\\| | N_obj near, without | N_obj near, with (share) | "
        "N_obj far, with | expected share | object px near / far | near GT-HS PSNR without → with (GT-PC) | far "
        "GT-HS PSNR without → with (GT-PC) | near / far PC-HS PSNR without → with |\n"
     << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Json& s : report["scenes"]) {
    if (!s.contains("semantic")) continue;
    for (const Json& r : s["semantic"]) {
      md << "| " << s["name"].get<std::string>() << " | " << r["query"].get<std::string>() << " ("
         << r["kind"].get<std::string>() << ") | ";
      if (r.contains("error")) {
        md << r["error"].get<std::string>() << " | | | | | | | | | | | |\n";
        continue;
      }
      const Json& near = r["views"]["near"];
      const Json& far = r["views"]["far"];
      md << integer(r["model_gaussians"]) << " | " << integer(r["budget"]) << " | " << cell(r["rho"], 2) << " | "
         << integer(r["object_gaussians"]) << " | " << integer(near["without_query"]["resident_on_object"]) << " | "
         << integer(near["with_query"]["resident_on_object"]) << " (" << percent(near["with_query"]["share"])
         << ") | " << integer(far["with_query"]["resident_on_object"]) << " | " << percent(r["expected_share"])
         << (r["share_matches"].get<bool>() ? "" : " **MISMATCH**") << " | " << integer(near["object_pixels"])
         << " / " << integer(far["object_pixels"]) << " | "
         << metric(near["without_query"]["gt_hs_object"], "psnr_db", 2) << " → "
         << metric(near["with_query"]["gt_hs_object"], "psnr_db", 2) << " ("
         << metric(near["gt_pc_object"], "psnr_db", 2) << ") | "
         << metric(far["without_query"]["gt_hs_object"], "psnr_db", 2) << " → "
         << metric(far["with_query"]["gt_hs_object"], "psnr_db", 2) << " ("
         << metric(far["gt_pc_object"], "psnr_db", 2) << ") | "
         << metric(near["without_query"]["pc_hs_object"], "psnr_db", 2) << " → "
         << metric(near["with_query"]["pc_hs_object"], "psnr_db", 2) << " / "
         << metric(far["without_query"]["pc_hs_object"], "psnr_db", 2) << " → "
         << metric(far["with_query"]["pc_hs_object"], "psnr_db", 2) << " |\n";
    }
  }
  md << "\n";
  if (!images) return;
  md << "Each panel: GT | HS without the query | FLIP(GT, without) | HS with the query | FLIP(GT, with); the "
        "FLIP maps cover the target's pixels only. Without ground truth PC takes GT's place.\n\n";
  for (const Json& s : report["scenes"]) {
    if (!s.contains("semantic")) continue;
    for (const Json& r : s["semantic"]) {
      if (r.contains("error")) continue;
      for (const char* v : {"near", "far"}) {
        const std::string f = s["name"].get<std::string>() + "_" + r["kind"].get<std::string>() + "_" + v + ".png";
        md << "![" << f << "](" << f << ")\n";
      }
    }
  }
  md << "\n";
}

// The timing entry of scene `name` (null without --timing).
const Json& scene_timing(const Json& report, const std::string& name) {
  static const Json kNull;
  if (!report.contains("timing")) return kNull;
  for (const Json& s : report["timing"]["scenes"])
    if (s["name"] == name) return s;
  return kNull;
}

void temporal_section(std::ostream& md, const Json& report) {
  bool any = false;
  for (const Json& s : report["scenes"]) any = any || s.contains("temporal");
  if (!any) return;
  md << "## Teleport, return, flicker (per publication mode)\n\n"
     << "From camera 0 (A) the client teleports to B (A mirrored through the room centre, looking the other "
        "way; around a scene file, a close-up of the far side looking at its centre), settles, and returns to A. *Published = desired*: virtual seconds from the return until the "
        "client's published set equals the host's sent set for good; *SSIM conv.*: until every later frame has "
        "SSIM ≥ 0.99 to the settled frame. Flicker: mean (max) absolute change per pixel and channel, 8-bit "
        "levels, between consecutive frames of A while the head sways; churn: slot writes / set membership "
        "changes / host messages in that window. Frame times (wall clock, while the return streams in) only "
        "with timing.\n\n";
  md << "| scene | mode | teleport: conv. s | return: published = desired s | return: SSIM conv. s | min SSIM | "
        "slot writes | flicker mean (max) | churn writes / changes / msgs | return frame CPU ms p50 / p95 / p99 |\n"
     << "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Json& s : report["scenes"]) {
    if (!s.contains("temporal")) continue;
    const Json& st = scene_timing(report, s["name"].get<std::string>());
    for (const Json& t : s["temporal"]) {
      const std::string mode = t["mode"].get<std::string>();
      const Json& f = t["flicker"];
      md << "| " << s["name"].get<std::string>() << " | " << mode << " | " << cell(t["teleport"]["converged_s"], 2)
         << " | " << cell(t["published_equals_desired_s"], 2) << " | " << cell(t["ssim_convergence_s"], 2) << " | "
         << cell(t["min_ssim_to_settled"], 3) << " | " << integer(t["return"]["slot_writes"]) << " | "
         << cell(f["mean_abs_change"], 3) << " (" << cell(f["max_abs_change"], 3) << ") | "
         << integer(f["slot_writes"]) << " / " << integer(f["membership_changes"]) << " / "
         << integer(f["host_messages"]) << " | ";
      if (st.is_object() && st["phases"].contains("temporal_frames")) {
        const Json& c = st["phases"]["temporal_frames"][mode]["return_frame_cpu_ms"];
        md << cell(c["p50"], 1) << " / " << cell(c["p95"], 1) << " / " << cell(c["p99"], 1);
      } else {
        md << "n/a";
      }
      md << " |\n";
    }
  }
  md << "\n";
}

void latency_section(std::ostream& md, const Json& report) {
  bool any = false;
  bool queries = false;  // a query row that resolved (scenes without objects have none)
  for (const Json& s : report["scenes"])
    for (const Json& r : s.contains("semantic") ? s["semantic"] : Json::array())
      queries = queries || (!r.contains("error") && r.contains("latency"));
  for (const Json& s : report["scenes"]) any = any || s.contains("model_latency") || queries;
  if (!any) return;
  md << "## Stage latencies (virtual seconds, from the event logs)\n\n";
  auto p50max = [](const Json& j) {
    return j.is_object() ? cell(j["p50"], 3) + " / " + cell(j["max"], 3) : std::string("n/a");
  };
  bool model = false;
  for (const Json& s : report["scenes"]) model = model || s.contains("model_latency");
  if (model) {
    md << "Model edits: the room produced live (a snapshot folder's snapshots or a capture's frames replayed), "
          "the first half of its epochs before the client connects, then one per period while it watches camera 0; "
          "from the epoch's commit on the host (available) to each stage, p50 / max over the epochs.\n\n"
       << "| scene | epochs | period s | → sent | → received | → published | → visible (first frame) |\n"
       << "|---|---|---|---|---|---|---|\n";
    for (const Json& s : report["scenes"]) {
      if (!s.contains("model_latency")) continue;
      const Json& l = s["model_latency"];
      md << "| " << s["name"].get<std::string>() << " | " << l["epochs"].size() << " | " << cell(l["epoch_period_s"], 2)
         << " | " << p50max(l["available_to_sent_s"]) << " | " << p50max(l["available_to_received_s"]) << " | "
         << p50max(l["available_to_published_s"]) << " | " << p50max(l["available_to_visible_s"]) << " |\n";
    }
    md << "\n";
  }
  if (!queries) return;
  md << "Queries: from the client issuing the query to the host resolving it, the first frame showing the "
        "highlight, the first frame with more target content resident (the client's event, and the harness's "
        "own count against the residency before the query), and the target's convergence.\n\n"
     << "| scene | query | M | → resolved | → highlight | → first additional (event / harness) | → converged | "
        "target resident before → at the event's start → desired |\n"
     << "|---|---|---|---|---|---|---|---|\n";
  for (const Json& s : report["scenes"]) {
    if (!s.contains("semantic")) continue;
    for (const Json& r : s["semantic"]) {
      if (r.contains("error") || !r.contains("latency")) continue;
      const Json& l = r["latency"];
      md << "| " << s["name"].get<std::string>() << " | " << r["query"].get<std::string>() << " | "
         << integer(r["budget"]) << " | " << cell(l["resolved_s"], 3) << " | " << cell(l["highlight_s"], 3) << " | "
         << cell(l["first_additional_s"], 3) << " / " << cell(l["first_more_resident_s"], 3) << " | "
         << cell(l["converged_s"], 3) << " | " << integer(l["resident_before_query"]) << " → "
         << integer(l["initial_residency"]) << " → " << integer(l["desired_residency"]) << " |\n";
    }
  }
  md << "\n";
}

void ablation_section(std::ostream& md, const Json& report, bool images) {
  bool any = false;
  for (const Json& s : report["scenes"]) any = any || s.contains("ablation");
  if (!any) return;
  md << "## Budget ablation\n\n"
     << "PC-HS (and GT-HS) means over the fidelity cameras at each budget M, each M on a fresh connection (LoD "
        "on: the host sends a coarse cut where the budget cannot hold the background's detail; off: its best "
        "Gaussians only). PC-HS over PC's pixels counts HS's holes as errors; the plain PC-HS is over the "
        "pixels both cover. The "
        "frame time is the client's GPU pass time p50 / p95 of idle frames at the settled views (wall clock, "
        "only with timing).\n\n"
     << "| scene | size | M | LoD | HS cover | PC-HS PSNR | PC-HS SSIM | PC-HS FLIP | PC-HS PSNR, PC's px | GT-HS PSNR "
        "| frame ms p50 / p95 |\n"
     << "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Json& s : report["scenes"]) {
    if (!s.contains("ablation")) continue;
    for (const Json& p : s["ablation"]) {
      std::string frame = "n/a";
      if (report.contains("ablation"))
        for (const Json& it : report["ablation"])
          if (it["scene"] == s["name"] && it["budget"] == p["budget"] && it["width"] == p["width"] &&
              it["height"] == p["height"] && it["lod"] == p["lod"])
            frame = cell(it["frame_ms_p50"], 2) + " / " + cell(it["frame_ms_p95"], 2);
      md << "| " << s["name"].get<std::string>() << " | " << integer(p["width"]) << "x" << integer(p["height"])
         << " | " << integer(p["budget"]) << " | " << (p["lod"].get<bool>() ? "on" : "off") << " | "
         << percent(p["coverage_hs"]) << " | " << cell(p["psnr_pc_hs"], 2) << " | " << cell(p["ssim_pc_hs"], 3)
         << " | " << cell(p["flip_pc_hs"], 3) << " | " << cell(p["psnr_pc_hs_all"], 2) << " | "
         << cell(p["psnr_gt_hs"], 2) << " | " << frame << " |\n";
    }
  }
  md << "\n";
  if (!images || !report.contains("plots")) return;
  if (report["plots"].is_string()) {
    md << "Plots: " << report["plots"].get<std::string>() << ".\n\n";
    return;
  }
  for (const Json& f : report["plots"]) md << "![" << f.get<std::string>() << "](" << f.get<std::string>() << ")\n";
  md << "\n";
}

constexpr const char* kPasses[] = {"upload", "mesh", "preprocess", "compact", "depth_sort", "emit", "tile_sort",
                                   "ranges", "blend"};
constexpr const char* kPassHeader =
    "upload | mesh | preprocess | compact | depth sort | emit | tile sort | ranges | blend |\n";

// " | p50 / p95 / p99" per pass of a {"pass": percentiles} object.
std::string pass_cells(const Json& passes) {
  std::string out;
  for (const char* p : kPasses) {
    const Json& v = passes.contains(p) ? passes[p] : Json();
    out += " | " + (v.is_object() ? cell(v["p50"], 2) + " / " + cell(v["p95"], 2) + " / " + cell(v["p99"], 2)
                                   : std::string("n/a"));
  }
  return out;
}

// Frame timing while publication runs, stereo at M = --stereo-budget (its deterministic
// part in the scene, its wall-clock figures under "timing").
void stereo_timing_section(std::ostream& md, const Json& report) {
  bool any = false;
  for (const Json& s : report["scenes"]) any = any || s.contains("stereo_timing");
  if (!any) return;
  md << "## Frame timing while publication runs (stereo)\n\n"
     << "Two eyes per frame, progressive publication at a fixed allowance on the client's publication thread "
        "(in lock step: each step, asked for in one frame, reaches the next; deterministic): idle at A, then a far "
        "teleport to B streaming in until the client converged, then idle at B; then frames at B back to back, "
        "without the simulated host's ticks between them (sustained: the GPU kept busy, at the clocks a busy GPU "
        "runs; an idling GPU lowers them). CPU: the display thread per frame "
        "(its publication share, uploads, rendering and the wait for the frame two back); GPU: both "
        "eyes, per frame and per pass (wall clock, on " << report["device"].get<std::string>() << ").\n\n"
     << "| scene | M | size | resident A / B | streaming frames (virtual s) | phase | frames | CPU ms p50 / p95 / p99 "
        "| GPU ms p50 / p95 / p99 |\n|---|---|---|---|---|---|---|---|---|\n";
  for (const Json& s : report["scenes"]) {
    if (!s.contains("stereo_timing")) continue;
    const Json& st = s["stereo_timing"];
    const Json& t = scene_timing(report, s["name"].get<std::string>());
    const Json& phases = t.is_object() && t.contains("stereo_timing") ? t["stereo_timing"]["phases"] : Json();
    for (const char* phase : {"idle_before", "streaming", "idle_after", "sustained"}) {
      const Json& p = phases.is_object() ? phases[phase] : Json();
      const Json& c = p.is_object() ? p["frame_cpu_ms"] : Json();
      const Json& g = p.is_object() ? p["frame_gpu_ms"] : Json();
      auto pct = [](const Json& j) {
        return j.is_object() ? cell(j["p50"], 1) + " / " + cell(j["p95"], 1) + " / " + cell(j["p99"], 1)
                             : std::string("n/a (no timing)");
      };
      md << "| " << s["name"].get<std::string>() << " | " << integer(st["budget"]) << " | " << integer(st["width"])
         << "x" << integer(st["height"]) << " | " << integer(st["resident_at_a"]) << " / "
         << integer(st["resident_at_b"]) << " | " << integer(st["teleport"]["frames"]) << " ("
         << cell(st["teleport"]["converged_s"], 2) << ") | " << phase << " | "
         << (c.is_object() ? integer(c["n"]) : std::string("n/a")) << " | " << pct(c) << " | " << pct(g) << " |\n";
    }
  }
  md << "\nGPU ms per pass (p50 / p95 / p99, both eyes):\n\n| scene | phase | " << kPassHeader
     << "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Json& s : report["scenes"]) {
    const Json& t = scene_timing(report, s["name"].get<std::string>());
    if (!s.contains("stereo_timing") || !t.is_object() || !t.contains("stereo_timing")) continue;
    for (const char* phase : {"idle_before", "streaming", "idle_after", "sustained"})
      md << "| " << s["name"].get<std::string>() << " | " << phase
         << pass_cells(t["stereo_timing"]["phases"][phase]["pass_gpu_ms"]) << " |\n";
  }
  md << "\n";
}

void timing_section(std::ostream& md, const Json& report) {
  if (!report.contains("timing")) return;
  const Json& t = report["timing"];
  md << "## Timing (wall clock, this machine)\n\n"
     << "Not part of the deterministic report: the client's display-thread CPU time and GPU pass time per "
        "frame on " << report["device"].get<std::string>() << ", while the runs above streamed and settled.\n\n"
     << "| scene | frames | CPU ms p50 / p95 / p99 | GPU ms p50 / p95 / p99 | wall s |\n|---|---|---|---|---|\n";
  for (const Json& s : t["scenes"]) {
    const Json& c = s["frame_cpu_ms"];
    const Json& g = s["frame_gpu_ms"];
    md << "| " << s["name"].get<std::string>() << " | " << integer(c["n"]) << " | " << cell(c["p50"], 2) << " / "
       << cell(c["p95"], 2) << " / " << cell(c["p99"], 2) << " | " << cell(g["p50"], 2) << " / " << cell(g["p95"], 2)
       << " / " << cell(g["p99"], 2) << " | " << cell(s["wall_s"], 1) << " |\n";
  }
  md << "\nGPU time per pass (ms, p50 / p95 / p99 over the same frames, views summed; the frames include "
        "those while publication ran):\n\n| scene | " << kPassHeader << "|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Json& s : t["scenes"]) {
    if (!s.contains("pass_gpu_ms")) continue;
    md << "| " << s["name"].get<std::string>() << pass_cells(s["pass_gpu_ms"]) << " |\n";
  }
  md << "\n";
}

// " p50 / p95 / p99" of a percentiles object.
std::string pct3(const Json& j, int digits) {
  return j.is_object() ? cell(j["p50"], digits) + " / " + cell(j["p95"], digits) + " / " + cell(j["p99"], digits)
                       : std::string("n/a");
}

void realtime_fidelity_section(std::ostream& md, const Json& report, bool images) {
  md << "## Fidelity: GT → PC → HS (realtime)\n\n"
     << "Each camera is its own connection to gauss-host: the client connects at the camera, settles, is captured "
        "and disconnects; the host then writes the set it sent, which is rendered in the client's slot order "
        "(*HS ≠ sent*, must be 0; *pub. = sent*: the client's published records equal the host's dump). Conv.: "
        "wall seconds from the connection until the client was quiet for good. Frame times per camera: CPU / GPU "
        "ms p50 / p95 / p99.\n\n";
  md << "| scene | cam | GT-PC PSNR | PC-HS PSNR | PC-HS SSIM | PC-HS FLIP | PC-HS PSNR, PC's px | GT-HS PSNR | GT-HS SSIM "
        "| GT-HS FLIP "
        "| cover PC / HS / both | resident | HS ≠ sent | pub. = sent | conv. s (wall) | frames | CPU ms | GPU ms |\n"
     << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Json& s : report["scenes"]) {
    for (const Json& c : s["realtime"]["fidelity"]["cameras"]) {
      const Json& st = c["settle"];
      md << "| " << s["name"].get<std::string>() << " | " << c["camera"].get<int>() << " | " << fidelity_cells(c)
         << " | "
         << (c["hs_vs_sent"]["published_equals_sent"].get<bool>() ? "yes" : "**NO**") << " | "
         << (st["converged"].get<bool>() ? cell(st["converged_s"], 2) : std::string("**not converged**")) << " | "
         << integer(st["frames"]) << " | " << pct3(st["frame_cpu_ms"], 2) << " | " << pct3(st["frame_gpu_ms"], 2)
         << " |\n";
    }
  }
  md << "\n";
  if (!images) return;
  md << "Each panel: GT | PC | HS | FLIP(PC, HS); without ground truth PC | HS | FLIP(PC, HS).\n\n";
  for (const Json& s : report["scenes"])
    for (const Json& c : s["realtime"]["fidelity"]["cameras"]) {
      const std::string f =
          s["name"].get<std::string>() + "_realtime_cam" + std::to_string(c["camera"].get<int>()) + ".png";
      md << "![" << f << "](" << f << ")\n";
    }
  md << "\n";
}

void realtime_teleport_section(std::ostream& md, const Json& report) {
  md << "## Teleport and return (realtime, per publication mode)\n\n"
     << "One connection per mode: settle at camera 0 (A), teleport to B (A mirrored through the room centre, "
        "looking the other way; around a scene file a close-up of the far side), settle, return to A and settle. "
        "Wall seconds from each move until the client was quiet for good; the return's frame times (ms p50 / p95 "
        "/ p99); then a flicker window at A (the head swaying, A rendered as a second view and compared frame to "
        "frame: the mean absolute change per pixel and channel in 8-bit levels, and the slot writes in the window); "
        "HS against the host's render of the set it sent after the return.\n\n"
     << "| scene | mode | at A s | A → B s | B → A s | return slot writes | return CPU ms | return GPU ms | "
        "flicker | window writes | HS ≠ sent | pub. = sent |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  auto conv = [](const Json& st) {
    return st["converged"].get<bool>() ? cell(st["converged_s"], 2) : std::string("**not converged**");
  };
  for (const Json& s : report["scenes"]) {
    for (const Json& t : s["realtime"]["teleport"]) {
      md << "| " << s["name"].get<std::string>() << " | " << t["mode"].get<std::string>() << " | "
         << conv(t["first"]) << " | " << conv(t["teleport"]) << " | " << conv(t["return"]) << " | "
         << integer(t["return"]["slot_writes"]) << " | " << pct3(t["return"]["frame_cpu_ms"], 2) << " | "
         << pct3(t["return"]["frame_gpu_ms"], 2) << " | " << cell(t["flicker"]["mean_abs_change"], 3) << " | "
         << integer(t["flicker"]["slot_writes"]) << " | " << integer(t["hs_vs_sent"]["differing_pixels"]) << " | "
         << (t["hs_vs_sent"]["published_equals_sent"].get<bool>() ? "yes" : "**NO**") << " |\n";
    }
  }
  md << "\n";
}

void realtime_semantic_section(std::ostream& md, const Json& report) {
  bool any = false;
  for (const Json& s : report["scenes"]) any = any || !s["realtime"]["semantic"].empty();
  if (!any) return;
  md << "## Semantic reallocation (realtime)\n\n"
     << "Per query one connection at its M, settled at the query's near view without the query, captured, then "
        "the query sent and settled again. N_obj: the client's resident Gaussians on the target; *expected* = "
        "min(|G_obj|, ⌊ρM⌋). Object PSNR over the target's pixels, without → with the query. Stages: wall "
        "seconds on the client's clock from sending the query to its targets arriving / the first frame knowing "
        "them / the first frame with more target content / the target converged.\n\n"
     << "| scene | object (query) | M | ρ | \\|G_obj\\| | N_obj without → with (share) | expected | object px | "
        "GT-HS PSNR | PC-HS PSNR | stages s (wall) | conv. s (wall) | HS ≠ sent |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const Json& s : report["scenes"]) {
    for (const Json& q : s["realtime"]["semantic"]) {
      md << "| " << s["name"].get<std::string>() << " | " << q["query"].get<std::string>() << " ("
         << q["kind"].get<std::string>() << ") | ";
      if (q.contains("error")) {
        md << q["error"].get<std::string>() << " | | | | | | | | | | |\n";
        continue;
      }
      const Json& w = q["without_query"];
      const Json& l = q["latency"];
      md << integer(q["budget"]) << " | " << cell(q["rho"], 2) << " | " << integer(q["object_gaussians"]) << " | "
         << integer(w["resident_on_object"]) << " → " << integer(q["resident_on_object"]) << " ("
         << percent(q["share"]) << ") | " << integer(q["expected_resident"])
         << (q["share_matches"].get<bool>() ? "" : " **MISMATCH**") << " | " << integer(q["object_pixels"]) << " | "
         << metric(w["gt_hs_object"], "psnr_db", 2) << " → " << metric(q["gt_hs_object"], "psnr_db", 2) << " | "
         << metric(w["pc_hs_object"], "psnr_db", 2) << " → " << metric(q["pc_hs_object"], "psnr_db", 2) << " | "
         << cell(l["targets_s"], 3) << " / " << cell(l["highlight_s"], 3) << " / " << cell(l["first_additional_s"], 3)
         << " / " << cell(l["converged_s"], 3) << " | "
         << (q["settle"]["converged"].get<bool>() ? cell(q["settle"]["converged_s"], 2)
                                                  : std::string("**not converged**"))
         << " | " << integer(q["hs_vs_sent"]["differing_pixels"]) << " |\n";
    }
  }
  md << "\n";
}

void realtime_host_section(std::ostream& md, const Json& report) {
  md << "## gauss-host processes\n\n"
     << "| scene | pid | port | final epoch | exit status | log |\n|---|---|---|---|---|---|\n";
  for (const Json& s : report["scenes"]) {
    const Json& h = s["realtime"]["host"];
    md << "| " << s["name"].get<std::string>() << " | " << integer(h["pid"]) << " | " << integer(h["port"]) << " | "
       << integer(h["final_epoch"]) << " | " << integer(h["exit_status"]) << " | " << h["log"].get<std::string>()
       << " |\n";
  }
  md << "\n";
}

// Which way is up in each scene file or capture, and where that came from (a room is +y).
void scene_up_lines(std::ostringstream& md, const Json& report) {
  bool any = false;
  for (const Json& scene : report["scenes"]) {
    if (!scene.contains("up")) continue;
    md << "**Up** of " << scene["name"].get<std::string>() << ": " << scene["up"]["axis"].get<std::string>() << ", from "
       << scene["up"]["from"].get<std::string>() << "; its cameras stand upright for it.\n";
    any = true;
  }
  if (any) md << "\n";
}

// report.md of a realtime run: wall-clock figures throughout, said at the top.
std::string realtime_markdown(const Json& report, bool images) {
  std::ostringstream md;
  md << "# gauss-eval report: " << report["name"].get<std::string>() << " (realtime)\n\n"
     << "Produced by\n\n```sh\nbuild/apps/" << report["command"].get<std::string>() << "\n```\n\n"
     << "on " << report["device"].get<std::string>() << ".\n\n"
     << "**Realtime run: every figure here is a wall-clock measurement** of gauss-host and the real client as "
        "separate processes over loopback ENet on this machine (its load included). Unlike the default "
        "deterministic report, these figures do not reproduce from run to run; the checks below do.\n\n";
  const Json& checks = report["checks"];
  auto yes = [&](const char* k) { return checks[k].get<bool>() ? "yes" : "**NO**"; };
  md << "**Checks:** HS equals the host's render of the set it sent at every view: " << yes("hs_equals_sent_render")
     << "; the client published exactly that set: " << yes("published_equals_sent")
     << "; the host served this evaluation's scene: " << yes("sent_matches_scene")
     << "; every semantic share equals min(|G_obj|, ⌊ρM⌋)/M: " << yes("semantic_shares_match")
     << "; every view converged: " << yes("all_converged")
     << "; Vulkan validation errors: " << integer(report["validation_errors"]) << ".\n\n";
  scene_up_lines(md, report);
  realtime_fidelity_section(md, report, images);
  realtime_teleport_section(md, report);
  realtime_semantic_section(md, report);
  realtime_host_section(md, report);
  md << "## Definitions\n\n";
  for (const auto& [k, v] : report["definitions"].items()) md << "- **" << k << "**: " << v.get<std::string>() << "\n";
  md << "\n";
  timing_section(md, report);
  return md.str();
}

}  // namespace

Status write_markdown(const std::filesystem::path& path, const Json& report, bool images) {
  if (report.contains("realtime")) {
    std::ofstream out(path);
    out << realtime_markdown(report, images);
    if (!out) return Error{"cannot write " + path.string()};
    return Ok{};
  }
  std::ostringstream md;
  md << "# gauss-eval report: " << report["name"].get<std::string>() << "\n\n"
     << "Produced by\n\n```sh\nbuild/apps/" << report["command"].get<std::string>() << "\n```\n\n"
     << "on " << report["device"].get<std::string>()
     << ". Everything except the timing section comes from a virtual clock and reproduces exactly "
        "(report.json, byte for byte, with --no-timing).\n\n";
  const Json& checks = report["checks"];
  md << "**Checks:** HS equals the host's render of the sent set at every view: "
     << (checks["hs_equals_sent_render"].get<bool>() ? "yes" : "**NO**")
     << "; every semantic share equals min(|G_obj|, ⌊ρM⌋)/M: "
     << (checks["semantic_shares_match"].get<bool>() ? "yes" : "**NO**")
     << "; every view converged: " << (checks["all_converged"].get<bool>() ? "yes" : "**NO**")
     << "; Vulkan validation errors: " << integer(report["validation_errors"]) << ".\n\n";
  scene_up_lines(md, report);
  fidelity_section(md, report, images);
  semantic_section(md, report, images);
  temporal_section(md, report);
  latency_section(md, report);
  ablation_section(md, report, images);
  stereo_timing_section(md, report);
  md << "## Definitions\n\n";
  for (const auto& [k, v] : report["definitions"].items()) md << "- **" << k << "**: " << v.get<std::string>() << "\n";
  md << "\n";
  timing_section(md, report);
  std::ofstream out(path);
  out << md.str();
  if (!out) return Error{"cannot write " + path.string()};
  return Ok{};
}

}  // namespace gauss::eval_app
