// The binary form of a garment (kiji/codec.h): its mesh with every property, material, texture,
// tacks, sleep record and step record, exactly.
#include "kiji/codec.h"

#include "base/archive.h"
#include "cloth/garment_soup.h"
#include "cloth/sleep_record_io.h"
#include "kiji/error.h"
#include "sim/solver_state.h"

#include <algorithm>

namespace kiji {

using detail::Field;

namespace {

// A garment's binary form but its texture (which the garment lends, rather than copy): what the
// garment holds as it is, and its mesh lowered to a soup.
struct GarmentForm {
  std::string name;
  Material material;
  Vec3 color = Vec3::Zero();
  double pattern_scale = 1;
  detail::Soup soup;  // its edges are in `edges`
  std::vector<std::pair<std::uint64_t, detail::EdgeData>> edges;  // in key order: equal garments, equal bytes
  detail::SleepingVertices asleep;
  // The step record (Garment::step_record), where the garment has one; its positions apart (the
  // record shares them, the form reads them into a list of its own).
  struct Step {
    bool present = false;
    StepRecord record;
    std::vector<Vec3> built_at;
    std::vector<std::vector<std::uint32_t>> anchors;  // level by level
    std::vector<std::uint8_t> built_alive;             // all 0 where the record does not say
  } step;
};

// The garment's fields, in the order they are in the binary form: encode_garment and
// decode_garment are these and nothing else.

template <class A>
void fields(A& a, Field<A, Material>& m, const DecodeLimits& limits) {
  a.str(m.name, limits.max_string, "the material's name");
  for (auto* v : {&m.density, &m.stretch_stiffness, &m.bending_stiffness, &m.damping, &m.friction, &m.thickness,
                  &m.tear_ratio})
    a.f64(*v);
  a.validate(m, "the material is out of range: ");
}

template <class A>
void fields(A& a, Field<A, Texture>& t, const DecodeLimits& limits) {
  std::uint32_t width = static_cast<std::uint32_t>(t.width), height = static_cast<std::uint32_t>(t.height);
  a.u32(width);
  a.u32(height);
  a.require(width <= limits.max_texture_side && height <= limits.max_texture_side && (width == 0) == (height == 0), [&] {
    return "the texture is " + std::to_string(width) + "x" + std::to_string(height) + "; at most " +
           std::to_string(limits.max_texture_side) + " texels a side";
  });
  a.raw(t.rgba, std::size_t(width) * height * 4);
  if constexpr (A::reading) {
    t.width = static_cast<int>(width);
    t.height = static_cast<int>(height);
  }
}

template <class A>
void fields(A& a, Field<A, GarmentForm>& g, Field<A, Texture>& texture, const DecodeLimits& limits) {
  a.version(kOperationFormatVersion, "garment");
  a.str(g.name, limits.max_string, "the garment's name");
  fields(a, g.material, limits);
  a.vec3(g.color, "the colour");
  a.finite(g.pattern_scale, "the pattern scale");
  a.require(g.pattern_scale > 0, "the pattern scale is not positive");
  fields(a, texture, limits);

  auto& s = g.soup;
  a.list(s.vertices, limits.max_vertices, 57, "the number of vertices", [&](auto& v) {
    a.boolean(v.alive, "a vertex's alive flag");
    a.vec3(v.position, "a vertex position");
    a.vec3(v.velocity, "a vertex velocity");
    a.finite(v.inverse_mass, "a vertex's inverse mass");
    a.require(v.inverse_mass >= 0, "a vertex has a negative inverse mass");
  });
  const std::size_t nv = s.vertices.size();
  const auto alive = [&](std::uint32_t v) { return v < nv && s.vertices[v].alive; };
  const std::size_t nf = a.count(s.faces, limits.max_faces, 64, "the number of faces");
  a.resize(s.uvs, nf);
  a.resize(s.panels, nf);
  for (std::size_t f = 0; f < nf; ++f) {
    for (auto& corner : s.faces[f]) {
      a.u32(corner);
      a.require(alive(corner), [&] { return "face " + std::to_string(f) + " uses a vertex that does not exist"; });
    }
    for (auto& uv : s.uvs[f]) a.vec2(uv, "a uv");
    a.i32(s.panels[f]);
  }
  a.list(g.edges, 3 * limits.max_faces + 3, 24, "the number of edges", [&](auto& edge) {
    auto& [key, e] = edge;
    a.u64(key);
    a.finite(e.rest, "an edge's rest length");
    a.finite(e.threshold, "an edge's tear threshold");
    a.require((key >> 32) < nv && (key & 0xffffffffu) < nv, "an edge names a vertex that does not exist");
    a.require(e.rest > 0 && e.threshold > 0, "an edge's rest length or tear threshold is not positive");
  });
  a.list(s.tacks, limits.max_vertices, 8, "the number of tacks", [&](auto& tack) {
    a.u32(tack.first);
    a.u32(tack.second);
    a.require(tack.first < nv && tack.second < nv, "a tack names a vertex that does not exist");
  });
  // Where it sleeps (garments written before this part end here, and wake whole).
  auto& asleep = g.asleep;
  if (a.more() && a.count(asleep.vertices, limits.max_vertices, 4, "the number of sleeping vertices") > 0) {
    for (auto& d : asleep.physics) a.finite(d, "the sleeping cloth's physics");
    for (std::size_t k = 0; k < asleep.vertices.size(); ++k) {
      a.u32(asleep.vertices[k]);
      a.require(alive(asleep.vertices[k]), "a sleeping vertex does not exist");
      a.require(k == 0 || asleep.vertices[k] > asleep.vertices[k - 1], "the sleeping vertices are not in ascending order");
    }
  }
  // What the solver carried from its last step: only where there is one, so that a garment never
  // stepped, or one written before this part, ends here.
  auto& step = g.step;
  auto& st = step.record;
  if constexpr (A::reading) step.present = a.more();
  if (step.present) {
    a.u64(st.mesh);
    a.list(step.built_at, limits.max_vertices, 24, "the number of the step record's vertices",
           [&](auto& p) { a.vec3(p, "where a vertex lay when the solver was built"); });
    a.require(step.built_at.size() == nv, "the step record is not of the garment's vertices");
    a.resize(st.surprise, nv);
    a.resize(st.surprise_self, nv);
    a.resize(st.held_up, nv);
    for (std::size_t i = 0; i < nv; ++i) {
      a.finite(st.surprise[i], "a vertex's collision margin");
      a.finite(st.surprise_self[i], "a vertex's self-collision margin");
      a.u8(st.held_up[i]);
    }
    a.boolean(st.sleep_ready, "whether the solver had its sleeping blocks");
    if (st.sleep_ready) {
      for (auto& d : st.physics) a.finite(d, "the physics the cloth settled in");
      const std::size_t blocks = a.count(st.asleep, SolverArrays::kMaxBlocks, 17, "the number of sleeping blocks");
      a.resize(st.calm, blocks);
      a.resize(st.block_key, blocks);
      for (std::size_t b = 0; b < blocks; ++b) {
        a.u8(st.asleep[b]);
        a.finite(st.calm[b], "how long a block has been calm");
        a.u64(st.block_key[b]);
      }
      a.resize(st.anchor, nv);
      for (auto& p : st.anchor) a.vec3(p, "where a vertex's calm began");
    }
    // The long-range anchors (records written before this part end here; a solver then sweeps
    // for its anchors anew).
    if (a.more())
      a.list(step.anchors, 6, 4, "the number of the step record's long-range levels", [&](auto& level) {
        a.list(level, limits.max_vertices, 4, "the number of a long-range level's anchors", [&](auto& v) {
          a.u32(v);
          a.require(v < nv, "a long-range anchor is not a vertex of the garment");
        });
      });
    // Which vertices the record's build had, one byte each (records written before this part end
    // here; a solver then takes its order from where the cloth lies, not from the record's).
    if (a.more()) {
      a.raw(step.built_alive, nv);
      for (std::uint8_t b : step.built_alive) a.require(b <= 1, "whether a vertex was built is not 0 or 1");
    }
  }
  a.end(" after the garment");
}

}  // namespace

std::string encode_garment(const Garment& g) {
  GarmentForm form{g.name, g.material(), g.color, g.pattern_scale(), detail::to_soup(g), {}, detail::sleeping_vertices(g), {}};
  // A record of the mesh before an edit (no step since) is written too, at the garment's size (its
  // vertices past the record's as none it had): a solver takes the long-range anchors from it, and
  // must find the same after a save or on a peer that joins.
  const std::size_t nv = form.soup.vertices.size();
  if (const StepRecord* r = g.step_record().get(); r && r->built_at && r->built_at->size() <= nv) {
    form.step.present = true;
    form.step.record = *r;
    form.step.built_at = *r->built_at;
    if (r->anchors)
      for (const std::vector<int>& level : *r->anchors) form.step.anchors.emplace_back(level.begin(), level.end());
    form.step.built_alive.assign(nv, 0);
    if (r->built_alive && r->built_alive->size() == r->built_at->size())
      std::copy(r->built_alive->begin(), r->built_alive->end(), form.step.built_alive.begin());
    StepRecord& st = form.step.record;
    if (r->built_at->size() < nv) {
      form.step.built_at.resize(nv, Vec3::Zero());
      st.surprise.resize(nv, 0.0);
      st.surprise_self.resize(nv, 0.0);
      st.held_up.resize(nv, 0);
      if (st.sleep_ready) st.anchor.resize(nv, Vec3::Zero());
    }
  }
  form.edges.assign(form.soup.edges.begin(), form.soup.edges.end());
  std::sort(form.edges.begin(), form.edges.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  detail::WriteArchive a;
  fields(a, form, g.texture(), DecodeLimits{});
  return a.take();
}

Garment decode_garment(std::string_view bytes, const DecodeLimits& limits) {
  detail::ReadArchive a(bytes, "garment data");
  Garment g;
  GarmentForm form;
  fields(a, form, g.texture(), limits);
  if (form.soup.faces.empty()) throw InputError("garment data has no faces: a garment needs at least one triangle");
  detail::Soup& s = form.soup;
  s.edges.reserve(form.edges.size());
  for (const auto& [key, e] : form.edges) s.edges[key] = e;
  g.name = std::move(form.name);
  g.set_material(form.material);
  g.color = form.color;
  g.set_pattern_scale(form.pattern_scale);
  try {
    detail::check_manifold(s, "garment data");
    detail::commit(g, s, "garment data");
  } catch (const TopologyError& e) {
    throw InputError(std::string("garment data does not describe a valid mesh: ") + e.what());
  }
  // The masses as they were, not as commit() recomputes them, so that the state is kept exactly.
  auto& m = g.mesh();
  auto inverse_mass = m.property_map<Vertex, double>("v:inverse_mass").first;
  for (Vertex v : m.vertices()) inverse_mass[v] = s.vertices[v.idx()].inverse_mass;
  detail::restore_sleep_record(g, form.asleep);
  if (form.step.present) {
    form.step.record.built_at = std::make_shared<const std::vector<Vec3>>(std::move(form.step.built_at));
    if (!form.step.anchors.empty()) {
      auto levels = std::make_shared<std::vector<std::vector<int>>>();
      for (const auto& level : form.step.anchors) levels->emplace_back(level.begin(), level.end());
      form.step.record.anchors = std::move(levels);
    }
    const auto& alive = form.step.built_alive;
    if (std::find(alive.begin(), alive.end(), 1) != alive.end())
      form.step.record.built_alive = std::make_shared<const std::vector<unsigned char>>(alive.begin(), alive.end());
    g.set_step_record(std::make_shared<const StepRecord>(std::move(form.step.record)));
  }
  return g;
}

}  // namespace kiji
