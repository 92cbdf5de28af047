#include "viewport.h"

#include "studio.h"
#include "kiji/topology.h"

#include <QKeyEvent>
#include <QMouseEvent>
#include <QOpenGLContext>
#include <QPainter>
#include <QWheelEvent>
#include <QWidget>

#include <algorithm>
#include <limits>
#include <cmath>

namespace kiji::studio {

namespace {

// Labels over the view (sizes, peers' names) are bold and smoothed, to read over cloth and body.
QFontMetrics bold_text(QPainter& painter) {
  painter.setRenderHint(QPainter::Antialiasing);
  QFont font = painter.font();
  font.setBold(true);
  painter.setFont(font);
  return QFontMetrics(font);
}

// How far in front of the cloth the mouse's pointer sits: within every tool's touch distance (the
// paint brush's is 5 mm), and clear of the surface so that the pick ray from it meets the cloth.
constexpr double kAboveCloth = 0.002;
// How near the cursor a border must be seen, in pixels, for a press to pick it.
constexpr double kBorderReach = 14;
// Colours of what the view draws to aim with.
const Vec3 kFirstSide(0.15, 0.45, 1.0), kSecondSide(1.0, 0.5, 0.05), kPairs(0.1, 0.75, 0.3);
const Vec3 kReach(1.0, 0.85, 0.1), kSewn(1.0, 0.97, 0.8), kSelected(0.25, 0.6, 1.0), kDrop(0.2, 0.22, 0.3);

void push(std::vector<float>& xyz, const Vec3& p) { xyz.insert(xyz.end(), {float(p.x()), float(p.y()), float(p.z())}); }

// A circle of radius r about c in the plane with normal n.
std::vector<float> circle(const Vec3& c, const Vec3& n, double r, int segments = 40) {
  const Vec3 u = n.unitOrthogonal(), v = n.normalized().cross(u);
  std::vector<float> out;
  for (int i = 0; i < segments; ++i) {
    const double a = 2 * M_PI * i / segments;
    push(out, c + r * (std::cos(a) * u + std::sin(a) * v));
  }
  return out;
}

// A dashed line from a to b: dashes of `dash` metres with gaps as long.
std::vector<float> dashed(const Vec3& a, const Vec3& b, double dash) {
  std::vector<float> out;
  const double length = (b - a).norm();
  if (!(length > 0)) return out;
  const Vec3 d = (b - a) / length;
  for (double t = 0; t < length; t += 2 * dash) {
    push(out, a + t * d);
    push(out, a + std::min(t + dash, length) * d);
  }
  return out;
}

QString centimetres(double metres) { return QString("%1 cm").arg(metres * 100, 0, 'f', metres < 0.1 ? 1 : 0); }

}  // namespace

QSurfaceFormat Viewport::surface_format() {
  QSurfaceFormat format = QSurfaceFormat::defaultFormat();
  format.setVersion(3, 3);
  format.setProfile(QSurfaceFormat::CoreProfile);
  format.setDepthBufferSize(std::max(24, format.depthBufferSize()));
  return format;
}

Viewport::Viewport(Studio& studio) : studio_(studio) {
  setFormat(surface_format());
  timer_.setTimerType(Qt::PreciseTimer);
  connect(&timer_, &QTimer::timeout, this, &Viewport::tick);
  timer_.start(16);
  fps_clock_.start();
  connect(this, &QOpenGLWindow::frameSwapped, this, [this] {
    if (continuous_) update();
  });
}

Viewport::~Viewport() { release_gl(); }

QWidget* Viewport::widget(QWidget* parent) {
  if (!container_) {
    container_ = QWidget::createWindowContainer(this, parent);
    container_->setMinimumSize(320, 240);
    container_->setFocusPolicy(Qt::StrongFocus);
  }
  return container_;
}

void Viewport::release_gl() {
  if (!gl_ready_ || !context()) return;
  makeCurrent();
  renderer_.release();
  doneCurrent();
  gl_ready_ = false;
}

void Viewport::set_edge_display(EdgeDisplay mode) {
  options_.edges = mode;
  dirty_ = true;
}

void Viewport::set_continuous(bool on) {
  continuous_ = on;
  update();
}

void Viewport::initializeGL() {
  connect(context(), &QOpenGLContext::aboutToBeDestroyed, this, &Viewport::release_gl, Qt::UniqueConnection);
  const QSurfaceFormat f = context()->format();
  if (f.majorVersion() < 3 || (f.majorVersion() == 3 && f.minorVersion() < 3)) {
    gl_error_ = QString("OpenGL %1.%2 is too old to draw the scene: Kiji Studio needs 3.3 (Mesa's llvmpipe gives it "
                        "without a GPU: LIBGL_ALWAYS_SOFTWARE=1)")
                    .arg(f.majorVersion())
                    .arg(f.minorVersion());
  } else if (!renderer_.initialize(context()->extraFunctions(), &gl_error_)) {
    gl_error_ = "The viewport's shaders did not build: " + gl_error_;
  } else {
    gl_ready_ = true;
    return;
  }
  emit gl_failed(gl_error_);
}

void Viewport::resizeGL(int, int) { dirty_ = true; }

void Viewport::paintGL() {
  if (!gl_ready_) {
    QOpenGLContext* c = QOpenGLContext::currentContext();
    if (c) {
      c->functions()->glClearColor(0.5f, 0.5f, 0.5f, 1);
      c->functions()->glClear(GL_COLOR_BUFFER_BIT);
    }
    return;
  }
  const auto frame = studio_.frame();
  if (!frame) return;
  if (pending_frame_) {
    camera_.frame(*pending_frame_, double(width()) / std::max(1, height()));
    pending_frame_.reset();
  } else if (!framed_once_ && !frame->bounds().isEmpty()) {
    camera_.frame(frame->bounds(), double(width()) / std::max(1, height()));
    framed_once_ = true;
  }
  options_.show_pointer = studio_.device_kind() == DeviceKind::Phantom || cursor_inside_ || drag_ == Drag::Stroke;
  const qreal dpr = devicePixelRatio();
  const auto peers = studio_.peer_view();
  Overlay overlay;
  std::vector<std::pair<Vec3, QString>> labels;
  build_overlay(*frame, overlay, labels);
  renderer_.draw(*frame, camera_, options_, int(width() * dpr), int(height() * dpr), peers.get(), &overlay);
  if (peers) draw_peer_names(*peers);
  if (!labels.empty()) {
    QPainter painter(this);
    const QFontMetrics metrics = bold_text(painter);
    for (const auto& [at, text] : labels) {
      const QPointF p = project(at);
      const QRectF box(p + QPointF(12, -metrics.height() - 8), QSizeF(metrics.horizontalAdvance(text) + 10, metrics.height() + 4));
      painter.setPen(Qt::NoPen);
      painter.setBrush(QColor(20, 20, 30, 200));
      painter.drawRoundedRect(box, 3, 3);
      painter.setPen(Qt::white);
      painter.drawText(box, Qt::AlignCenter, text);
    }
  }
  drawn_peers_ = peers;
  studio_.set_viewpoint(camera_.eye(), camera_.target);
  drawn_frame_ = frame->number;
  dirty_ = false;
  ++frames_drawn_;
  const qint64 now = fps_clock_.elapsed();
  frame_times_.push_back(now);
  while (!frame_times_.empty() && frame_times_.front() < now - 1000) frame_times_.pop_front();
  fps_ = frame_times_.size() > 1 ? 1000.0 * (frame_times_.size() - 1) / double(frame_times_.back() - frame_times_.front()) : 0;
}

bool Viewport::seam_mode() const {
  if (studio_.tool(kButtonPrimary) != "sew") return false;
  const ParamSet& p = studio_.tool_params(kButtonPrimary);
  try {
    return p.get_string("mode") == "seam";
  } catch (const std::exception&) {
    return false;
  }
}

double Viewport::tool_float(const char* name, double fallback) const {
  const ParamSet& p = studio_.tool_params(kButtonPrimary);
  try {
    return p.get_float(name);
  } catch (const std::exception&) {
    return fallback;
  }
}

void Viewport::say(const QString& text) {
  if (text == hint_) return;
  hint_ = text;
  emit hint(text);
}

void Viewport::build_overlay(const SceneFrame& frame, Overlay& overlay, std::vector<std::pair<Vec3, QString>>& labels) {
  const Vec3 eye = camera_.eye();
  // Lines on the cloth are drawn a millimetre towards the eye, so that the cloth does not hide them.
  auto lifted = [&](const Vec3& p) { return Vec3(p + 0.001 * (eye - p).normalized()); };
  const double scale = camera_.distance / 3.0;

  // Seams closing: each tacked pair joined by a thin line, until the simulation draws it shut.
  for (std::size_t gi = 0; gi < frame.garments.size(); ++gi) {
    const GarmentFrame& g = frame.garments[gi];
    const GarmentShape* shape = g.tacks.empty() ? nullptr : shapes_.get(frame, gi);
    if (!shape) continue;
    OverlayLines closing{{}, kSewn, GL_LINES, 1.5f, 0.8f};
    for (std::size_t k = 0; k + 1 < g.tacks.size(); k += 2) {
      push(closing.xyz, lifted(shape->position(g, g.tacks[k])));
      push(closing.xyz, lifted(shape->position(g, g.tacks[k + 1])));
    }
    overlay.lines.push_back(std::move(closing));
  }

  // The seams sewn: dashed, as stitches.
  for (std::size_t gi = 0; gi < frame.garments.size(); ++gi) {
    const GarmentShape* shape = shapes_.get(frame, gi);
    if (!shape || shape->seams.empty()) continue;
    const auto& p = frame.garments[gi].positions;
    OverlayLines stitches{{}, kSewn, GL_LINES, 2.5f};
    for (std::size_t k = 0; k + 1 < shape->seams.size(); k += 2) {
      const std::uint32_t a = shape->seams[k], b = shape->seams[k + 1];
      const Vec3 pa(p[3 * a], p[3 * a + 1], p[3 * a + 2]), pb(p[3 * b], p[3 * b + 1], p[3 * b + 2]);
      push(stitches.xyz, lifted(pa + 0.15 * (pb - pa)));
      push(stitches.xyz, lifted(pa + 0.85 * (pb - pa)));
    }
    overlay.lines.push_back(std::move(stitches));
  }

  // The piece selected.
  if (selection_.garment >= 0) {
    const GarmentShape* shape = shapes_.get(frame, std::size_t(selection_.garment));
    int piece = -1;
    if (shape && selection_.vertex < shape->render_of.size() && shape->render_of[selection_.vertex] != kNone) {
      const auto& t = shape->topology->triangles;
      for (std::size_t f = 0; f < shape->piece_of_triangle.size() && piece < 0; ++f)
        for (int c = 0; c < 3; ++c)
          if (shape->topology->mesh_vertex[t[3 * f + c]] == selection_.vertex) piece = shape->piece_of_triangle[f];
    }
    if (piece < 0) {
      clear_selection();
    } else {
      overlay.tints.push_back({std::size_t(selection_.garment), shape->piece_triangles(piece), kSelected, 0.45f});
    }
  }

  const bool seam = seam_mode();
  // The seam being picked: its sides, the stretch being dragged, and the pairs it will join.
  if (seam) {
    const int gi = seams_.garment();
    const GarmentShape* shape = gi >= 0 ? shapes_.get(frame, std::size_t(gi)) : nullptr;
    seams_.check(gi >= 0 ? shape : nullptr);
    auto side_line = [&](const std::vector<std::uint32_t>& side, const Vec3& colour, float width) {
      OverlayLines l{{}, colour, GL_LINE_STRIP, width, 1, true};
      for (std::uint32_t v : side) push(l.xyz, shape->position(frame.garments[std::size_t(gi)], v));
      overlay.lines.push_back(l);
      OverlayLines ends{{}, colour, GL_POINTS, 10, 1, true};
      push(ends.xyz, shape->position(frame.garments[std::size_t(gi)], side.front()));
      overlay.lines.push_back(ends);
    };
    if (shape) {
      if (!seams_.first().empty()) side_line(seams_.first(), kFirstSide, 4);
      const auto second = seams_.second();
      if (!second.empty()) side_line(second, kSecondSide, 4);
      if (seams_.picking() && seams_.stretch().size() >= 1)
        side_line(seams_.stretch(), seams_.stage() == SeamPicker::Stage::First ? kFirstSide : kSecondSide, 4);
      if (seams_.stage() == SeamPicker::Stage::Ready) {
        OverlayLines pairs{{}, kPairs, GL_LINES, 1.5f, 1, true};
        const auto all = seams_.pairs(frame.garments[std::size_t(gi)], *shape);
        for (const auto& pr : all) {
          push(pairs.xyz, pr.a);
          push(pairs.xyz, pr.b);
        }
        overlay.lines.push_back(pairs);
        if (!all.empty()) {
          // The first pair thicker: which ends meet.
          OverlayLines first{{}, kPairs, GL_LINES, 4, 1, true};
          push(first.xyz, all.front().a);
          push(first.xyz, all.front().b);
          overlay.lines.push_back(first);
        }
      }
    }
    // The border under the cursor, and the side a click would take.
    if (!seams_.picking() && seams_.stage() != SeamPicker::Stage::Ready && cursor_inside_ && drag_ == Drag::None &&
        studio_.device_kind() != DeviceKind::Phantom) {
      const BorderHit h = border_near(cursor_, kBorderReach);
      if (h.vertex != kNone) {
        const GarmentShape* hs = shapes_.get(frame, std::size_t(h.garment));
        const Vec3 colour = seams_.stage() == SeamPicker::Stage::First ? kFirstSide : kSecondSide;
        OverlayLines side{{}, colour, GL_LINE_STRIP, 2, 0.45f, true};
        for (std::uint32_t v : hs->side_of(h.vertex)) push(side.xyz, hs->position(frame.garments[std::size_t(h.garment)], v));
        overlay.lines.push_back(side);
        OverlayLines dot{{}, colour, GL_POINTS, 12, 1, true};
        push(dot.xyz, hs->position(frame.garments[std::size_t(h.garment)], h.vertex));
        overlay.lines.push_back(dot);
      }
    }
    say(seams_.hint());
  }

  // The trail of the stroke while it is drawn: for a cut, the line it will cut; for other tools a
  // thin line, so that what they leave shows.
  static const QString kClosing = "the cut closes here: let go to cut out what it encloses";
  bool closing = false;
  if (trail_live_ && trail_.size() >= 2) {
    const bool cut = studio_.tool(buttons_ == kButtonSecondary ? kButtonSecondary : kButtonPrimary) == "cut";
    OverlayLines line{{}, cut ? Vec3(0.85, 0.05, 0.1) : Vec3(0.95, 0.45, 0.1), GL_LINE_STRIP, cut ? 2.5f : 1.5f,
                      cut ? 1.0f : 0.6f};
    for (const Vec3& p : trail_) push(line.xyz, lifted(p));
    overlay.lines.push_back(line);
    // A cut that will close (the cut tool's rule): its closing piece and a ring where it began, so
    // that the user sees the inside will come away before letting go.
    if (cut) {
      const std::uint32_t button = buttons_ == kButtonSecondary ? kButtonSecondary : kButtonPrimary;
      const ParamSet& params = studio_.tool_params(button);
      if (params.get_string("mode") == "line" && knife_line_closes(trail_, params.get_float("close"))) {
        OverlayLines piece{{}, Vec3(0.85, 0.05, 0.1), GL_LINES, 2.5f, 1.0f};
        push(piece.xyz, lifted(trail_.back()));
        push(piece.xyz, lifted(trail_.front()));
        overlay.lines.push_back(piece);
        OverlayLines ring{{}, Vec3(0.85, 0.05, 0.1), GL_POINTS, 16, 1, true};
        push(ring.xyz, lifted(trail_.front()));
        overlay.lines.push_back(ring);
        say(kClosing);
        closing = true;
      }
    }
  }
  if (!closing && hint_ == kClosing) say({});

  // The pointer: a drop line and a shadow where it would come down on the cloth or the body.
  drop_.reset();
  sew_target_.reset();
  if (frame.has_pointer && options_.show_pointer) {
    const Vec3 tip = frame.pointer.position;
    const RayHit below = cast_ray(frame, tip, Vec3(0, -1, 0), true);
    double floor = frame.body ? frame.body->bounds().min().y() : 0.0;
    if (!std::isfinite(floor)) floor = 0;
    const Vec3 land = below.hit ? below.point : Vec3(tip.x(), std::min(floor, tip.y()), tip.z());
    // Down to the floor only for a Phantom's pen or cloth a stroke holds: a mouse cursor over
    // nothing floats on the view's plane, and its line would cross the picture and mean nothing.
    const bool in_air = studio_.device_kind() == DeviceKind::Phantom || frame.stroke_holds_cloth;
    if (below.hit || in_air) drop_ = land;
    if (drop_ && (tip - land).norm() > 0.004) {
      overlay.lines.push_back({dashed(tip, land, 0.006 * scale), kDrop, GL_LINES, 1.5f, 0.8f});
      const double r = 0.012 * scale;
      for (double k : {1.0, 0.6, 0.25})
        overlay.lines.push_back({circle(land + Vec3(0, 0.001, 0), Vec3::UnitY(), k * r), kDrop, GL_LINE_LOOP, 2, 0.6f});
    }
  }

  // What a press would act on: the tool's reach on the cloth.
  if (!seam && frame.has_pointer && options_.show_pointer && frame.hit.hit && !frame.stroke_active) {
    const std::string tool = studio_.tool(kButtonPrimary);
    double reach = tool_float("radius", 0);
    if (reach <= 0) reach = tool_float("grab_radius", 0);
    if (reach > 0)
      overlay.lines.push_back({circle(lifted(frame.hit.point), frame.hit.normal, reach), kReach, GL_LINE_LOOP, 2});
    if (tool == "sew") {
      // The border vertex a sew would take (as the tool finds it), bold.
      const double within = 3 * std::max(tool_float("distance", 0.01), 0.01);
      const BorderHit h = border_near(frame.hit.point, within);
      if (h.vertex != kNone) {
        OverlayLines dot{{}, Vec3(0.1, 0.8, 0.9), GL_POINTS, 12, 1, true};
        push(dot.xyz, shapes_.get(frame, std::size_t(h.garment))->position(frame.garments[std::size_t(h.garment)], h.vertex));
        overlay.lines.push_back(dot);
      }
    }
  }

  // A vertex dragged by the sew tool: the vertex it would be sewn to, green within the sewing
  // distance, orange as it comes near, with the distance between them.
  if (frame.stroke_active && frame.stroke_tool == "sew" && !seam && sewn_vertex_ != kNone) {
    const double distance = tool_float("distance", 0.01);
    for (std::size_t gi = 0; gi < frame.garments.size(); ++gi) {
      const GarmentShape* shape = shapes_.get(frame, gi);
      if (!shape || !shape->on_border(sewn_vertex_)) continue;
      const GarmentFrame& g = frame.garments[gi];
      const Vec3 dragged = shape->position(g, sewn_vertex_);
      const auto& loop = shape->loops[shape->loop_of[sewn_vertex_]];
      const int n = int(loop.size()), at = shape->place_in_loop[sewn_vertex_];
      std::uint32_t best = kNone;
      double best_d = 6 * std::max(distance, 0.005);
      for (const auto& l : shape->loops)
        for (std::uint32_t v : l) {
          if (v == sewn_vertex_ || v == loop[(at + 1) % n] || v == loop[(at + n - 1) % n]) continue;
          const double d = (shape->position(g, v) - dragged).norm();
          if (d < best_d) best_d = d, best = v;
        }
      overlay.lines.push_back({circle(dragged, eye - dragged, std::max(distance, 0.002)), Vec3(0.1, 0.8, 0.9), GL_LINE_LOOP, 1.5f, 0.8f, true});
      if (best != kNone) {
        const Vec3 target = shape->position(g, best);
        const Vec3 colour = best_d <= distance ? kPairs : Vec3(1.0, 0.55, 0.1);
        OverlayLines link{{}, colour, GL_LINES, 2.5f, 1, true};
        push(link.xyz, dragged);
        push(link.xyz, target);
        overlay.lines.push_back(link);
        OverlayLines dot{{}, colour, GL_POINTS, 12, 1, true};
        push(dot.xyz, target);
        overlay.lines.push_back(dot);
        labels.emplace_back(target, best_d <= distance ? "sews here" : centimetres(best_d));
        sew_target_ = SewTarget{target, best_d, best_d <= distance};
      }
      break;
    }
  }
}

void Viewport::tick() {
  const auto frame = studio_.frame();
  // With the sew tool in seam mode the buttons pick borders: the device makes no strokes meanwhile.
  const bool seam = seam_mode();
  if (seam != picking_) {
    picking_ = seam;
    studio_.set_picking(seam);
    if (!seam) {
      seams_.clear();
      say({});
    }
    dirty_ = true;
  }
  if (frame) {
    if (seam && studio_.device_kind() == DeviceKind::Phantom) follow_phantom(*frame);
    // A stroke of a device other than the mouse leaves its trail too.
    if (studio_.device_kind() == DeviceKind::Phantom) {
      if (frame->stroke_active && !trail_live_) {
        trail_.clear();
        trail_live_ = true;
      }
      if (frame->stroke_active && frame->has_pointer)
        trail_.push_back(frame->hit.hit ? frame->hit.point : frame->pointer.position);
      if (!frame->stroke_active && trail_live_) {
        trail_live_ = false;
      }
    }
  }
  if (continuous_) return;
  if (dirty_ || (frame && frame->number != drawn_frame_) || studio_.peer_view() != drawn_peers_) update();
  // With nothing drawn for a second, the rate shown is zero, not the last one measured.
  if (!frame_times_.empty() && fps_clock_.elapsed() - frame_times_.back() > 1000) {
    frame_times_.clear();
    fps_ = 0;
  }
}

void Viewport::follow_phantom(const SceneFrame& frame) {
  if (!frame.has_pointer) return;
  const std::uint32_t buttons = frame.pointer.buttons;
  const bool down1 = (buttons & kButtonPrimary) && !(phantom_buttons_ & kButtonPrimary);
  const bool up1 = !(buttons & kButtonPrimary) && (phantom_buttons_ & kButtonPrimary);
  const bool down2 = (buttons & kButtonSecondary) && !(phantom_buttons_ & kButtonSecondary);
  phantom_buttons_ = buttons;
  const BorderHit h = border_near(frame.pointer.position, 0.03);
  const GarmentShape* shape = h.garment >= 0 ? shapes_.get(frame, std::size_t(h.garment)) : nullptr;
  if (down2) seams_.flip();
  if (down1) {
    if (seams_.stage() == SeamPicker::Stage::Ready) sew_picked_seam();
    else if (shape) seams_.press(h.garment, h.vertex, *shape);
  } else if ((buttons & kButtonPrimary) && seams_.picking() && shape && h.garment == seams_.garment()) {
    seams_.drag(h.vertex, *shape);
  }
  if (up1 && seams_.picking()) {
    const GarmentShape* own = shapes_.get(frame, std::size_t(seams_.garment()));
    if (own) seams_.release(frame.garments[std::size_t(seams_.garment())], *own);
  }
  dirty_ = true;
}

Viewport::BorderHit Viewport::border_near(const QPointF& at, double pixels, int only_garment, int only_loop,
                                          std::uint32_t continuing) {
  BorderHit best;
  const auto frame = studio_.frame();
  if (!frame) return best;
  struct Candidate {
    double pixels;
    int garment;
    std::uint32_t vertex;
    Vec3 position;
  };
  std::vector<Candidate> near;
  for (std::size_t gi = 0; gi < frame->garments.size(); ++gi) {
    if (only_garment >= 0 && int(gi) != only_garment) continue;
    const GarmentShape* shape = shapes_.get(*frame, gi);
    if (!shape) continue;
    for (std::size_t l = 0; l < shape->loops.size(); ++l) {
      if (only_loop >= 0 && int(l) != only_loop) continue;
      for (std::uint32_t v : shape->loops[l]) {
        const Vec3 p = shape->position(frame->garments[gi], v);
        const double d = std::hypot(project(p).x() - at.x(), project(p).y() - at.y());
        if (d <= pixels) near.push_back({d, int(gi), v, p});
      }
    }
  }
  std::sort(near.begin(), near.end(), [](const Candidate& a, const Candidate& b) { return a.pixels < b.pixels; });
  if (continuing != kNone && only_garment >= 0) {
    // A drag goes on along the border: a vertex reached from `continuing` only round the loop (in
    // a side view, the other panel's border lies under the cursor, across the hem) is dropped.
    const GarmentFrame& g = frame->garments[std::size_t(only_garment)];
    const GarmentShape* shape = shapes_.get(*frame, std::size_t(only_garment));
    const Vec3 start = shape->position(g, continuing);
    auto direct = [&](const Candidate& c) {
      double best = std::numeric_limits<double>::infinity();
      for (bool forward : {true, false}) {
        const auto path = shape->along(continuing, c.vertex, forward);
        double length = 0;
        for (std::size_t i = 1; i < path.size(); ++i) length += (shape->position(g, path[i]) - shape->position(g, path[i - 1])).norm();
        if (!path.empty()) best = std::min(best, length);
      }
      return best <= 1.5 * (c.position - start).norm() + 0.03;
    };
    near.erase(std::remove_if(near.begin(), near.end(), [&](const Candidate& c) { return !direct(c); }), near.end());
  }
  // The nearest seen: not behind cloth or body (a few tried, nearest first).
  const Vec3 eye = camera_.eye();
  for (std::size_t i = 0; i < near.size() && i < 6; ++i) {
    const Vec3 to = near[i].position - eye;
    const RayHit h = cast_ray(*frame, eye, to.normalized(), true);
    if (h.hit && h.t < to.norm() - 0.01) continue;
    return {near[i].garment, near[i].vertex};
  }
  return best;
}

Viewport::BorderHit Viewport::border_near(const Vec3& at, double reach) {
  BorderHit best;
  const auto frame = studio_.frame();
  if (!frame) return best;
  double best_d = reach;
  for (std::size_t gi = 0; gi < frame->garments.size(); ++gi) {
    const GarmentShape* shape = shapes_.get(*frame, gi);
    if (!shape) continue;
    for (const auto& loop : shape->loops)
      for (std::uint32_t v : loop) {
        const double d = (shape->position(frame->garments[gi], v) - at).norm();
        if (d <= best_d) best_d = d, best = {int(gi), v};
      }
  }
  return best;
}

bool Viewport::sew_picked_seam() {
  if (seams_.stage() != SeamPicker::Stage::Ready) return false;
  const int garment = seams_.garment();
  const auto first = seams_.first(), second = seams_.second();
  seams_.clear();
  dirty_ = true;
  return studio_.sew_seam(garment, first, second);
}

void Viewport::clear_selection() {
  if (selection_.garment < 0) return;
  selection_ = {};
  dirty_ = true;
  say({});
  emit selection_changed();
}

void Viewport::set_view(View view) {
  switch (view) {
    case View::Front: camera_.yaw = 0, camera_.pitch = 0.1; break;
    case View::Back: camera_.yaw = M_PI, camera_.pitch = 0.1; break;
    case View::Right: camera_.yaw = M_PI / 2, camera_.pitch = 0.1; break;
    case View::Left: camera_.yaw = -M_PI / 2, camera_.pitch = 0.1; break;
    case View::Top: camera_.yaw = 0, camera_.pitch = 1.55; break;
  }
  has_plane_ = false;
  frame_all();
  dirty_ = true;
}

void Viewport::frame_all() {
  const auto frame = studio_.frame();
  if (!frame || frame->bounds().isEmpty()) return;
  framed_once_ = true;
  has_plane_ = false;
  dirty_ = true;
  if (width() <= 0 || height() <= 0) {
    pending_frame_ = frame->bounds();  // not shown yet: framed when it is
    return;
  }
  pending_frame_.reset();
  camera_.frame(frame->bounds(), double(width()) / height());
}

void Viewport::draw_peer_names(const PeerView& peers) {
  QPainter painter(this);
  const QFontMetrics metrics = bold_text(painter);
  for (const PeerRow& p : peers.peers) {
    if (p.self || !p.present || !p.has_presence || p.presence.pointer == Vec3::Zero()) continue;
    // A label beside the pen's tip, in the peer's colour: who is pointing there.
    const QPointF at = project(p.presence.pointer);
    const QString name = QString::fromStdString(p.name);
    const QRectF box(at + QPointF(10, -metrics.height() - 6), QSizeF(metrics.horizontalAdvance(name) + 10, metrics.height() + 4));
    const QColor colour = QColor::fromRgbF(float(p.colour.x()), float(p.colour.y()), float(p.colour.z()));
    painter.setPen(Qt::NoPen);
    painter.setBrush(colour);
    painter.drawRoundedRect(box, 3, 3);
    painter.setPen(colour.lightnessF() > 0.55 ? Qt::black : Qt::white);
    painter.drawText(box, Qt::AlignCenter, name);
  }
}

QPointF Viewport::project(const Vec3& p) const {
  const double aspect = double(width()) / std::max(1, height());
  const Eigen::Vector4f clip =
      camera_.projection(aspect) * camera_.view() * Eigen::Vector4f(float(p.x()), float(p.y()), float(p.z()), 1.0f);
  return QPointF((clip.x() / clip.w() + 1) * 0.5 * width(), (1 - clip.y() / clip.w()) * 0.5 * height());
}

Vec3 Viewport::cursor_ray(const QPointF& at) const {
  const double x = 2.0 * at.x() / std::max(1, width()) - 1.0;
  const double y = 1.0 - 2.0 * at.y() / std::max(1, height());
  return camera_.ray(x, y, double(width()) / std::max(1, height()));
}

void Viewport::push_pointer(const QPointF& at, std::uint32_t buttons) {
  MouseDevice* mouse = studio_.mouse();
  if (!mouse) return;
  const Vec3 eye = camera_.eye(), dir = cursor_ray(at), n = camera_.forward();
  if (!has_plane_) {
    plane_point_ = camera_.target;
    has_plane_ = true;
  }
  const auto frame = studio_.frame();
  const bool pulling = drag_ == Drag::Stroke && frame && frame->stroke_active && frame->stroke_holds_cloth;
  Vec3 pointer;
  double t = 0;
  const RayHit hit = frame && !pulling ? cast_ray(*frame, eye, dir, false) : RayHit{};
  if (hit.hit) {
    t = hit.t;
    pointer = eye + (t - kAboveCloth) * dir;
    // The plane a pull would move on goes through the cloth just found.
    plane_point_ = pointer;
  } else {
    const double denom = dir.dot(n);
    t = std::abs(denom) > 1e-9 ? (plane_point_ - eye).dot(n) / denom : camera_.distance;
    if (t <= camera_.near_plane()) t = camera_.distance;
    pointer = eye + t * dir;
  }
  ToolEvent e;
  e.phase = Phase::Move;
  e.position = pointer;
  e.ray = dir;
  e.orientation = camera_.orientation();
  e.buttons = buttons;
  mouse->push(e);
  buttons_ = buttons;
}

void Viewport::mousePressEvent(QMouseEvent* e) {
  last_ = pressed_at_ = cursor_ = e->position();
  moved_ = false;
  const bool alt = e->modifiers() & Qt::AltModifier;
  if (e->button() == Qt::MiddleButton || (e->button() == Qt::LeftButton && alt)) {
    drag_ = (e->modifiers() & Qt::ShiftModifier) ? Drag::Pan : Drag::Orbit;
    return;
  }
  if (drag_ != Drag::None) return;
  const auto frame = studio_.frame();
  if (e->button() == Qt::LeftButton && (e->modifiers() & Qt::ControlModifier)) {
    // Ctrl + click: the piece of cloth under the cursor is selected (Delete removes it).
    selection_ = {};
    if (frame) {
      const RayHit h = cast_ray(*frame, camera_.eye(), cursor_ray(e->position()), false);
      const GarmentShape* shape = h.hit ? shapes_.get(*frame, std::size_t(h.garment)) : nullptr;
      if (shape) {
        selection_ = {h.garment, shape->topology->mesh_vertex[shape->topology->triangles[3 * h.triangle]]};
        say("A piece is selected: Delete removes it (Esc: none)");
      }
    }
    if (selection_.garment < 0) say({});
    dirty_ = true;
    emit selection_changed();
    return;
  }
  if (seam_mode() && frame) {
    if (e->button() == Qt::RightButton) {
      seams_.flip();
    } else if (e->button() == Qt::LeftButton) {
      if (seams_.stage() == SeamPicker::Stage::Ready) {
        drag_ = Drag::SeamSew;
      } else {
        const BorderHit h = border_near(e->position(), kBorderReach);
        if (h.vertex != kNone && seams_.press(h.garment, h.vertex, *shapes_.get(*frame, std::size_t(h.garment))))
          drag_ = Drag::SeamPick;
      }
    }
    dirty_ = true;
    return;
  }
  if (e->button() == Qt::LeftButton || e->button() == Qt::RightButton) {
    drag_ = Drag::Stroke;
    const std::uint32_t button = e->button() == Qt::LeftButton ? kButtonPrimary : kButtonSecondary;
    trail_.clear();
    trail_live_ = true;
    sewn_vertex_ = kNone;
    if (frame) {
      const RayHit h = cast_ray(*frame, camera_.eye(), cursor_ray(e->position()), false);
      if (h.hit) {
        trail_.push_back(h.point);
        // The border vertex a sew stroke takes, as the tool finds it.
        if (studio_.tool(button) == "sew") {
          const BorderHit b = border_near(h.point, 3 * std::max(tool_float("distance", 0.01), 0.01));
          sewn_vertex_ = b.vertex;
        }
      }
    }
    push_pointer(e->position(), button);
  }
}

void Viewport::mouseMoveEvent(QMouseEvent* e) {
  cursor_inside_ = true;
  const QPointF d = e->position() - last_;
  last_ = cursor_ = e->position();
  if ((e->position() - pressed_at_).manhattanLength() > 4) moved_ = true;
  if (drag_ == Drag::Orbit) {
    camera_.orbit(-d.x() * 0.008, d.y() * 0.008);
    has_plane_ = false;
    dirty_ = true;
  } else if (drag_ == Drag::Pan) {
    camera_.pan(-d.x() / std::max(1, height()), d.y() / std::max(1, height()));
    has_plane_ = false;
    dirty_ = true;
  } else if (drag_ == Drag::SeamPick) {
    const auto frame = studio_.frame();
    const int gi = seams_.garment();
    const GarmentShape* shape = frame && gi >= 0 ? shapes_.get(*frame, std::size_t(gi)) : nullptr;
    if (shape && !seams_.stretch().empty()) {
      // Along the border the drag began on, within a generous reach of the cursor.
      const BorderHit h = border_near(e->position(), 3 * kBorderReach, gi, shape->loop_of[seams_.stretch().front()],
                                      seams_.stretch().back());
      if (h.vertex != kNone) seams_.drag(h.vertex, *shape);
    }
    push_pointer(e->position(), 0u);
    dirty_ = true;
  } else if (drag_ == Drag::SeamSew) {
    push_pointer(e->position(), 0u);
  } else {
    push_pointer(e->position(), drag_ == Drag::Stroke ? buttons_ : 0u);
    if (drag_ == Drag::Stroke) {
      const auto frame = studio_.frame();
      if (frame) {
        const RayHit h = cast_ray(*frame, camera_.eye(), cursor_ray(e->position()), false);
        if (h.hit) trail_.push_back(h.point);
      }
    }
    dirty_ = true;
  }
}

void Viewport::mouseReleaseEvent(QMouseEvent* e) {
  if (drag_ == Drag::Stroke && (e->button() == Qt::LeftButton || e->button() == Qt::RightButton)) {
    push_pointer(e->position(), 0u);
    drag_ = Drag::None;
    trail_live_ = false;
    sewn_vertex_ = kNone;
  } else if (drag_ == Drag::SeamPick && e->button() == Qt::LeftButton) {
    drag_ = Drag::None;
    const auto frame = studio_.frame();
    const int gi = seams_.garment();
    const GarmentShape* shape = frame && gi >= 0 ? shapes_.get(*frame, std::size_t(gi)) : nullptr;
    if (shape) seams_.release(frame->garments[std::size_t(gi)], *shape);
    else seams_.clear();
    dirty_ = true;
  } else if (drag_ == Drag::SeamSew && e->button() == Qt::LeftButton) {
    drag_ = Drag::None;
    if (!moved_) sew_picked_seam();
  } else if ((drag_ == Drag::Orbit || drag_ == Drag::Pan) &&
             (e->button() == Qt::MiddleButton || e->button() == Qt::LeftButton)) {
    drag_ = Drag::None;
  }
}

void Viewport::wheelEvent(QWheelEvent* e) {
  const double notches = e->angleDelta().y() / 120.0;
  if (drag_ == Drag::Stroke) {
    // The plane the pull moves on, nearer or farther: 1 % of the view's distance a notch.
    plane_point_ -= notches * 0.01 * camera_.distance * camera_.forward();
    push_pointer(last_, buttons_);
    return;
  }
  // Towards what is under the cursor, which stays where it is seen (else the point at the target's
  // depth under it).
  const Vec3 eye = camera_.eye(), dir = cursor_ray(e->position());
  Vec3 at;
  const auto frame = studio_.frame();
  const RayHit h = frame ? cast_ray(*frame, eye, dir, true) : RayHit{};
  if (h.hit) {
    at = h.point;
  } else {
    const double denom = dir.dot(camera_.forward());
    at = eye + (std::abs(denom) > 1e-9 ? (camera_.target - eye).dot(camera_.forward()) / denom : camera_.distance) * dir;
  }
  const double before = camera_.distance;
  camera_.zoom(std::pow(0.9, notches));
  const double f = camera_.distance / before;
  // The eye moves along its line to `at`: target and eye both scale about it.
  camera_.target = at + f * (camera_.target - at);
  has_plane_ = false;
  dirty_ = true;
}

bool Viewport::event(QEvent* e) {
  if (e->type() == QEvent::Enter || e->type() == QEvent::Leave) {
    cursor_inside_ = e->type() == QEvent::Enter;
    dirty_ = true;
  }
  return QOpenGLWindow::event(e);
}

void Viewport::keyPressEvent(QKeyEvent* e) {
  const bool ctrl = e->modifiers() & Qt::ControlModifier;
  switch (e->key()) {
    case Qt::Key_F: frame_all(); return;
    case Qt::Key_1: set_view(ctrl ? View::Back : View::Front); return;
    case Qt::Key_3: set_view(ctrl ? View::Left : View::Right); return;
    case Qt::Key_7: set_view(View::Top); return;
    case Qt::Key_Escape:
      seams_.clear();
      clear_selection();
      dirty_ = true;
      return;
    case Qt::Key_Return:
    case Qt::Key_Enter:
      if (seams_.stage() == SeamPicker::Stage::Ready) sew_picked_seam();
      return;
    case Qt::Key_R:
      if (!ctrl && seams_.stage() == SeamPicker::Stage::Ready) {
        seams_.flip();
        dirty_ = true;
        return;
      }
      break;
    default: break;
  }
  QOpenGLWindow::keyPressEvent(e);
}

}  // namespace kiji::studio
