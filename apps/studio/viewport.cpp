#include "viewport.h"

#include "studio.h"

#include <QKeyEvent>
#include <QMouseEvent>
#include <QOpenGLContext>
#include <QPainter>
#include <QWheelEvent>
#include <QWidget>

#include <cmath>

namespace kiji::studio {

namespace {

// How far in front of the cloth the mouse's pointer sits: within every tool's touch distance (the
// paint brush's is 5 mm), and clear of the surface so that the pick ray from it meets the cloth.
constexpr double kAboveCloth = 0.002;

}  // namespace

Viewport::Viewport(Studio& studio) : studio_(studio) {
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
  renderer_.draw(*frame, camera_, options_, int(width() * dpr), int(height() * dpr), peers.get());
  if (peers) draw_peer_names(*peers);
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

void Viewport::tick() {
  const auto frame = studio_.frame();
  if (continuous_) return;
  if (dirty_ || (frame && frame->number != drawn_frame_) || studio_.peer_view() != drawn_peers_) update();
  // With nothing drawn for a second, the rate shown is zero, not the last one measured.
  if (!frame_times_.empty() && fps_clock_.elapsed() - frame_times_.back() > 1000) {
    frame_times_.clear();
    fps_ = 0;
  }
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
  painter.setRenderHint(QPainter::Antialiasing);
  QFont font = painter.font();
  font.setBold(true);
  painter.setFont(font);
  const QFontMetrics metrics(font);
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

bool Viewport::pick_cloth(const Vec3& o, const Vec3& d, double* best) const {
  const auto frame = studio_.frame();
  if (!frame) return false;
  bool found = false;
  *best = std::numeric_limits<double>::infinity();
  for (const GarmentFrame& g : frame->garments) {
    if (!g.topology) continue;
    const std::vector<std::uint32_t>& tri = g.topology->triangles;
    const float* p = g.positions.data();
    auto at = [&](std::uint32_t i) { return Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]); };
    for (std::size_t k = 0; k + 2 < tri.size(); k += 3) {
      // Moller-Trumbore.
      const Vec3 a = at(tri[k]), e1 = at(tri[k + 1]) - a, e2 = at(tri[k + 2]) - a;
      const Vec3 h = d.cross(e2);
      const double det = e1.dot(h);
      if (std::abs(det) < 1e-14) continue;
      const double inv = 1.0 / det;
      const Vec3 s = o - a;
      const double u = inv * s.dot(h);
      if (u < 0 || u > 1) continue;
      const Vec3 q = s.cross(e1);
      const double v = inv * d.dot(q);
      if (v < 0 || u + v > 1) continue;
      const double t = inv * e2.dot(q);
      if (t > 0 && t < *best) {
        *best = t;
        found = true;
      }
    }
  }
  return found;
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
  if (!pulling && pick_cloth(eye, dir, &t)) {
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
  last_ = e->position();
  const bool alt = e->modifiers() & Qt::AltModifier;
  if (e->button() == Qt::MiddleButton || (e->button() == Qt::LeftButton && alt)) {
    drag_ = (e->modifiers() & Qt::ShiftModifier) ? Drag::Pan : Drag::Orbit;
    return;
  }
  if (drag_ != Drag::None) return;
  if (e->button() == Qt::LeftButton || e->button() == Qt::RightButton) {
    drag_ = Drag::Stroke;
    push_pointer(e->position(), e->button() == Qt::LeftButton ? kButtonPrimary : kButtonSecondary);
  }
}

void Viewport::mouseMoveEvent(QMouseEvent* e) {
  cursor_inside_ = true;
  const QPointF d = e->position() - last_;
  last_ = e->position();
  if (drag_ == Drag::Orbit) {
    camera_.orbit(-d.x() * 0.008, d.y() * 0.008);
    has_plane_ = false;
    dirty_ = true;
  } else if (drag_ == Drag::Pan) {
    camera_.pan(-d.x() / std::max(1, height()), d.y() / std::max(1, height()));
    has_plane_ = false;
    dirty_ = true;
  } else {
    push_pointer(e->position(), drag_ == Drag::Stroke ? buttons_ : 0u);
  }
}

void Viewport::mouseReleaseEvent(QMouseEvent* e) {
  if (drag_ == Drag::Stroke && (e->button() == Qt::LeftButton || e->button() == Qt::RightButton)) {
    push_pointer(e->position(), 0u);
    drag_ = Drag::None;
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
  camera_.zoom(std::pow(0.9, notches));
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
  if (e->key() == Qt::Key_F) frame_all();
  else QOpenGLWindow::keyPressEvent(e);
}


}  // namespace kiji::studio
