#include "scene_setup.h"

#include "kiji/drape.h"
#include "kiji/error.h"
#include "kiji/pattern.h"
#include "kiji/session.h"

#include <cmath>
#include <sstream>

namespace kiji::studio {

Garment GarmentSpec::make() const {
  const Material m = Material::preset(material);
  Garment g;
  if (kind == Kind::Rectangle) {
    RectSpec r{width, height, spacing};
    r.validate();
    g = make_rectangle_spaced(width, height, spacing, m);
  } else {
    g = make_panel(outline, spacing, m);
  }
  g.name = kind == Kind::Rectangle ? "rectangle" : "panel";
  return g;
}

std::string GarmentSpec::describe() const {
  std::ostringstream s;
  if (kind == Kind::Rectangle) s << "rectangle " << width << " x " << height << " m";
  else s << "panel of " << outline.size() << " corners";
  s << ", " << spacing << " m apart, " << material;
  return s.str();
}

GarmentSpec GarmentSpec::rectangle(const std::string& text) {
  const RectSpec r = RectSpec::parse(text);
  GarmentSpec g;
  g.width = r.width;
  g.height = r.height;
  g.spacing = r.spacing;
  return g;
}

std::size_t add_garment(Session& session, const GarmentSpec& spec) {
  Garment g = spec.make();
  if (session.body()) {
    place_over_body(g, *session.body());
  } else {
    const Box3 b = g.bounds();
    g.transform(Eigen::Affine3d(Eigen::Translation3d(Vec3(-b.center().x(), 1.7 - b.max().y(), 0))));
    const Box3 placed = g.bounds();
    const Vec3 corners[2] = {Vec3(placed.min().x(), placed.max().y(), 0), Vec3(placed.max().x(), placed.max().y(), 0)};
    for (const Vec3& c : corners) {
      Vertex best;
      double d = 1e300;
      for (Vertex v : g.mesh().vertices())
        if ((g.position(v) - c).squaredNorm() < d) d = (g.position(v) - c).squaredNorm(), best = v;
      g.set_pinned(best, true);
    }
  }
  return session.add_garment(g);
}

bool has_strokes(const Session& session) {
  for (const Operation& op : session.journal().operations())
    if (std::holds_alternative<op::ToolInput>(op.data)) return true;
  return false;
}

void lay_over_body(Session& session) {
  if (!session.body()) return;
  for (std::size_t i = 0; i < session.garment_count(); ++i) {
    Garment g = session.garment(i);
    place_over_body(g, *session.body());
    session.set_garment(i, g);
  }
}

}  // namespace kiji::studio
