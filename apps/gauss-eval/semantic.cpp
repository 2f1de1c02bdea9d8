// The semantic reallocation table: a class and an instance query, each on its own
// connection with a fixed budget, with and without the query.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <strings.h>

#include "measurements.h"

namespace gauss::eval_app {

std::vector<QuerySpec> query_specs(const SceneStore& store, const Options& o) {
  std::vector<QuerySpec> specs;
  QuerySpec c;
  c.kind = "class";
  c.name = o.class_query;
  c.query = SemanticQuery::for_class(o.class_query);
  c.wire.kind = msg::QueryKind::ClassText;
  c.wire.text = o.class_query;
  c.wire.rho = msg::kHostDefaultRho;  // the host's rho (--rho): exactly the double asked for
  specs.push_back(std::move(c));
  // The instance query: the object --instance-id names, else the first object (lowest id)
  // with the label.
  const auto& objects = store.objects();
  const bool by_id = o.instance_id >= 0;
  const auto inst = std::find_if(objects.begin(), objects.end(), [&](const SemanticObject& ob) {
    return by_id ? to_underlying(ob.id) == o.instance_id : strcasecmp(ob.label.c_str(), o.instance_label.c_str()) == 0;
  });
  QuerySpec i;
  if (inst == objects.end()) {
    i.kind = "instance";
    i.name = by_id ? "#" + std::to_string(o.instance_id) : o.instance_label;
    i.error = by_id ? "no object with this id" : "no object with this label";
    specs.push_back(std::move(i));
    return specs;
  }
  i.kind = "instance";
  i.name = (by_id ? inst->label : o.instance_label) + " #" + std::to_string(to_underlying(inst->id));
  i.query = SemanticQuery::for_instance(inst->id);
  i.wire.kind = msg::QueryKind::Instance;
  i.wire.instance = inst->id;
  i.wire.rho = msg::kHostDefaultRho;
  specs.push_back(std::move(i));
  return specs;
}

// The target's pixels without ground truth: those the host's render of the target's
// appearance Gaussians alone covers.
Expected<std::unique_ptr<render::SplatRenderer>> target_renderer(Room& room, std::span<const ObjectId> targets) {
  std::vector<Gaussian> on;
  for (const Gaussian& g : appearance_gaussians(*room.scene.store))
    if (std::binary_search(targets.begin(), targets.end(), g.object)) on.push_back(g);
  auto r = render::SplatRenderer::create(room.context, {.capacity = static_cast<std::uint32_t>(std::max<std::size_t>(1, on.size())),
                                                        .sh_degree = room.scene.store->sh_degree(),
                                                        .max_width = room.options.width,
                                                        .max_height = room.options.height});
  if (!r) return Error{"the target's renderer: " + r.message()};
  if (auto st = (*r)->write_slots(0, on); !st) return Error{"the target's renderer: " + st.message()};
  return r;
}

namespace {

// Frames at `view` until the client's resolved query targets are (`want` = true) or are
// not (false) set, at most `timeout_s` virtual seconds: the query's round trip, so that a
// settle afterwards cannot take the frames before the host saw the query for convergence.
// `on_frame` (may be empty) sees every frame.
Status wait_for_query(EvalSession& session, const Camera& view, bool want, double timeout_s,
                      const std::function<void(const client::DisplayFrameStats&)>& on_frame = {}) {
  const double t0 = session.now();
  while (session.now() - t0 <= timeout_s) {
    const bool has = session.client().with_state([](const ClientState& s) { return !s.query_targets().empty(); });
    if (has == want) return Ok{};
    auto f = session.step(view);
    if (!f) return f.error();
    if (on_frame) on_frame(*f);
  }
  return Error{want ? "the query was not resolved in time" : "the query was not cleared in time"};
}

struct View {
  const char* name;
  Camera cam;
  std::optional<GroundTruthImage> gt;  // none for a scene file
  ImageRGBA8 pc;          // the host's render of the full scene
  eval::Mask mask;        // the target's pixels
  ImageRGBA8 hs[2];       // without, with the query
  Json json;
  // What the panels and FLIP maps compare against: GT when there is one, else PC.
  const ImageRGBA8& reference() const { return gt ? gt->colour : pc; }
};

// One query state (with or without it) at one view.
Expected<Json> measure_state(Room& room, Stream& stream, View& v, std::span<const ObjectId> targets, bool with,
                             const std::function<void(const client::DisplayFrameStats&)>& on_frame = {}) {
  auto cap = capture(room, stream, v.cam, on_frame);
  if (!cap) return cap.error();
  const std::uint64_t on_object = stream.session->resident_on(targets);
  Json j;
  j["settle"] = settle_json(cap->settle);
  j["resident"] = cap->resident;
  j["resident_on_object"] = on_object;
  j["share"] = double(on_object) / double(stream.session->client().capacity());
  j["gt_hs_object"] = v.gt ? scores(v.gt->colour, cap->hs, v.mask) : Json(nullptr);
  j["pc_hs_object"] = scores(v.pc, cap->hs, v.mask);
  j["hs_vs_sent_differing"] = cap->hs_vs_sent_differing;
  v.hs[with ? 1 : 0] = std::move(cap->hs);
  return j;
}

Expected<Json> measure_query(Room& room, const QuerySpec& q) {
  const EvalScene& scene = room.scene;
  const Options& o = room.options;
  auto res = resolve_query(q.query, scene.store->objects());
  if (!res) return Json{{"kind", q.kind}, {"query", q.name}, {"error", res.message()}};
  const std::vector<ObjectId> targets = res->ids();
  const auto [m, reserve, expected] = query_budget(o, res->gaussians);
  auto stream = open_stream(room, m, o.progressive ? PublishMode::Progressive : PublishMode::Immediate);
  if (!stream) return stream.error();
  Json row;
  row["kind"] = q.kind;
  row["query"] = q.name;
  Json ids = Json::array();
  for (ObjectId id : targets) ids.push_back(to_underlying(id));
  row["targets"] = ids;
  row["model_gaussians"] = scene.appearance;
  row["budget"] = m;
  row["rho"] = o.rho;
  row["object_gaussians"] = res->gaussians;
  row["reserve"] = reserve;
  row["expected_resident"] = expected;
  row["expected_share"] = double(expected) / double(m);
  const ObjectViews ov = scene.synthetic ? object_views(*res, *scene.synthetic, o.width, o.height)
                                         : object_views(*res, scene, o.width, o.height);
  View vs[2] = {{"near", ov.near, {}, {}, {}, {}, {}}, {"far", ov.far, {}, {}, {}, {}, {}}};
  std::unique_ptr<render::SplatRenderer> target_only;
  if (!scene.synthetic) {
    auto r = target_renderer(room, targets);
    if (!r) return r.error();
    target_only = std::move(*r);
  }
  for (View& v : vs) {
    v.gt = ground_truth(scene, v.cam);
    auto pc = render_covered(room.full, v.cam);
    if (!pc) return pc.error();
    v.pc = std::move(pc->image);
    if (v.gt) {
      v.mask = object_mask(*v.gt, targets);
    } else {
      auto alone = render_covered(*target_only, v.cam);
      if (!alone) return alone.error();
      v.mask = std::move(alone->cover);
    }
    v.json["pose"] = camera_json(v.cam);
    v.json["object_pixels"] = count(v.mask);
    v.json["object_pixels_from"] = v.gt ? "ground truth" : "render of the target alone";
    v.json["gt_pc_object"] = v.gt ? scores(v.gt->colour, v.pc, v.mask) : Json(nullptr);
  }
  EvalSession& session = *stream->session;
  bool matches = true;
  std::uint32_t query_id = 0;
  double sent_at = 0.0;
  // The harness's own view of the query's effect: target residency before the query and
  // the first frame (after it was issued) that holds more, until the near view settles.
  std::uint64_t base_resident = 0;
  double first_more = -1.0;
  bool tracking = false;
  const auto track = [&](const client::DisplayFrameStats& f) {
    if (tracking && first_more < 0.0 && session.resident_on(targets) > base_resident) first_more = f.now - sent_at;
  };
  for (bool with : {false, true}) {
    if (with) {
      base_resident = session.resident_on(targets);
      tracking = true;
      sent_at = session.now();
      query_id = session.client().send_query(q.wire);
      if (auto st = wait_for_query(session, vs[0].cam, true, o.settle_timeout_s, track); !st) return st.error();
    }
    for (View& v : vs) {
      room.progress("semantic " + q.name + ", " + v.name + (with ? ", with the query" : ", without"));
      auto st = measure_state(room, *stream, v, targets, with, track);
      tracking = false;
      if (!st) return Error{std::string(v.name) + ": " + st.message()};
      if (with) {
        const std::uint64_t got = (*st)["resident_on_object"].get<std::uint64_t>();
        (*st)["share_matches"] = got == expected;
        matches = matches && got == expected;
        (*st)["client_reported_object_gaussians"] =
            session.client().with_state([](const ClientState& s) { return s.query_target_gaussians(); });
      }
      v.json[with ? "with_query" : "without_query"] = std::move(*st);
    }
  }
  row["share_matches"] = matches;
  row["latency"] = query_latency(session, query_id, sent_at);
  row["latency"]["resident_before_query"] = base_resident;
  row["latency"]["first_more_resident_s"] = number(first_more);
  row["views"] = Json{{"near", std::move(vs[0].json)}, {"far", std::move(vs[1].json)}};
  row["stream"] = stream_json(session);
  if (room.panels.enabled()) {
    for (View& v : vs) {
      ImageRGBA8 diffs[2];
      for (int w = 0; w < 2; ++w) {
        auto fm = eval::flip_map(view_of(v.reference()), view_of(v.hs[w]), v.mask);
        diffs[w] = flip_image(fm ? *fm : std::vector<float>{}, o.width, o.height);
      }
      if (auto st = room.panels.write(scene.name + "_" + q.kind + "_" + v.name,
                                      {&v.reference(), &v.hs[0], &diffs[0], &v.hs[1], &diffs[1]});
          !st)
        return st.error();
    }
  }
  return row;
}

}  // namespace

QueryBudget query_budget(const Options& o, std::size_t object_gaussians) {
  QueryBudget b;
  b.m = o.semantic_budget > 0 ? o.semantic_budget : static_cast<std::uint32_t>(std::max<std::size_t>(16, object_gaussians));
  // floor(rho M) as the host computes it (the query leaves rho to the host's --rho).
  b.reserve = static_cast<std::uint64_t>(std::floor(o.rho * static_cast<double>(b.m)));
  b.expected = std::min<std::uint64_t>(object_gaussians, b.reserve);
  return b;
}

Expected<Json> measure_semantic(Room& room) {
  const auto t0 = std::chrono::steady_clock::now();
  Json rows = Json::array();
  for (const QuerySpec& q : query_specs(*room.scene.store, room.options)) {
    if (!q.error.empty()) {
      rows.push_back(Json{{"kind", q.kind}, {"query", q.name}, {"error", q.error}});
      continue;
    }
    auto row = measure_query(room, q);
    if (!row) return Error{room.scene.name + " query " + q.name + ": " + row.message()};
    rows.push_back(std::move(*row));
  }
  room.timing.phases["semantic_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return rows;
}

}  // namespace gauss::eval_app
