// The 3D view: draws the latest published frame (never waiting for a step), moves the camera
// (middle button or Alt + left: orbit; with Shift: pan; wheel: zoom towards the cursor; F: frame
// all; 1, 3, 7: front, right and top views, with Ctrl the opposite side) and, when the mouse is the
// pointing device, turns the cursor into a 3D pointer with a pick ray:
//  - hovering or drawing on the cloth (cut, paint), the pointer sits on the cloth under the cursor;
//    off the cloth, on a plane facing the camera;
//  - while a stroke holds cloth (pinch, tear, a sewn vertex), it moves on the plane through the
//    grabbed point facing the camera, and the wheel moves that plane nearer or farther.
// Left button: the primary tool; right button: the secondary one. Ctrl + left click selects the
// piece of cloth under the cursor.
//
// So that a press lands where the user means, it draws a drop line and a shadow from the pointer to
// the cloth or body below it, what a press would act on (the tool's reach on the cloth; the border
// vertex a sew would take and, while it is dragged, the vertex it would be sewn to, with the distance),
// the trail of a stroke as it is drawn (for a cut: the line it will cut, and whether it will close),
// and the seams sewn. With the sew tool in seam mode the buttons pick a seam's borders instead of
// making strokes (SeamPicker), for the mouse and a Phantom alike.
//
// In a shared session it also draws the other peers: their pens with their names, their viewpoints,
// and the cloth each holds.
//
// It is a QOpenGLWindow in a window container, not a QOpenGLWidget: for a QOpenGLWidget Qt composes
// the whole top-level window through OpenGL on every frame, which under Mesa's llvmpipe costs
// several times what the scene does (docs/benchmarks.md, "Kiji Studio").
#pragma once

#include "frame_shapes.h"
#include "orbit_camera.h"
#include "scene_renderer.h"
#include "seam_picker.h"

#include <QElapsedTimer>
#include <QOpenGLWindow>
#include <QSurfaceFormat>
#include <QTimer>

#include <deque>
#include <optional>

namespace kiji::studio {

class Studio;

class Viewport : public QOpenGLWindow {
  Q_OBJECT
 public:
  explicit Viewport(Studio& studio);
  ~Viewport() override;
  // What the view draws with: OpenGL 3.3 core (the shaders', and what Mesa gives without a GPU)
  // and a depth buffer. The viewport asks for it itself, so that a host which sets no default
  // format (a test, another application) does not draw the body and the cloth without depth.
  static QSurfaceFormat surface_format();
  // The widget that holds the view in a layout (made on the first call; owned by its parent).
  QWidget* widget(QWidget* parent = nullptr);

  OrbitCamera& camera() { return camera_; }
  DrawOptions& draw_options() { return options_; }
  void set_edge_display(EdgeDisplay mode);
  // Redraw as often as the GL allows (a benchmark), or when something changed, at most 60 times a
  // second (the default: the simulation and the haptic loop keep the cores).
  void set_continuous(bool on);
  double frames_per_second() const { return fps_; }
  std::uint64_t frames_drawn() const { return frames_drawn_; }
  std::size_t edges_drawn() const { return renderer_.edges_drawn(); }
  // Empty when the view draws; else why it cannot (no OpenGL 3.3).
  QString gl_error() const { return gl_error_; }
  // The point of the widget where a world point is seen.
  QPointF project(const Vec3& world) const;

  enum class View { Front, Back, Right, Left, Top };
  // Looks at the scene from a side (the body faces +Z: the front view looks at it from +Z), framed.
  void set_view(View view);

  // The seam being picked with the sew tool in seam mode.
  SeamPicker& seam_picker() { return seams_; }
  // Sews the seam picked (both sides); false if there is none or it was refused.
  bool sew_picked_seam();
  // The piece of cloth selected with Ctrl + click (garment -1: none) and a vertex of it.
  struct Selection {
    int garment = -1;
    std::uint32_t vertex = kNone;
  };
  const Selection& selection() const { return selection_; }
  void clear_selection();
  // The trail of the stroke in progress or the last one (world points on the cloth).
  const std::vector<Vec3>& trail() const { return trail_; }
  // Where the drop line from the pointer lands: the cloth or body below it; the floor only for a
  // Phantom's pen or cloth held by a stroke. None: no line (nothing below a mouse cursor, no pointer).
  std::optional<Vec3> drop_point() const { return drop_; }
  // While a pinch-sew drags a border vertex: the vertex it would be sewn to, as last drawn (its
  // position, the distance to it, and whether that is within the sewing distance).
  struct SewTarget {
    Vec3 at = Vec3::Zero();
    double distance = 0;
    bool within = false;
  };
  std::optional<SewTarget> sew_target() const { return sew_target_; }

 public slots:
  void frame_all();

 signals:
  void gl_failed(const QString& why);
  // What a press would do now (for the status bar); empty for nothing to say.
  void hint(const QString& text);
  void selection_changed();

 protected:
  void initializeGL() override;
  void paintGL() override;
  void resizeGL(int w, int h) override;
  void mousePressEvent(QMouseEvent* e) override;
  void mouseMoveEvent(QMouseEvent* e) override;
  void mouseReleaseEvent(QMouseEvent* e) override;
  void wheelEvent(QWheelEvent* e) override;
  void keyPressEvent(QKeyEvent* e) override;
  bool event(QEvent* e) override;  // the cursor coming in and going out

 private:
  enum class Drag { None, Orbit, Pan, Stroke, SeamPick, SeamSew };
  void tick();
  void release_gl();
  // Each other peer's name beside its pointer (over the GL picture).
  void draw_peer_names(const PeerView& peers);
  // The cursor as a 3D pointer for the mouse device.
  void push_pointer(const QPointF& at, std::uint32_t buttons);
  Vec3 cursor_ray(const QPointF& at) const;
  // The border vertex seen nearest a point of the view within `pixels` (not hidden by cloth or body
  // in front of it); only on `loop` of `garment` when those are given. With `continuing` (a vertex
  // of that loop), only a vertex the border reaches from it about as directly as a straight line.
  struct BorderHit {
    int garment = -1;
    std::uint32_t vertex = kNone;
  };
  BorderHit border_near(const QPointF& at, double pixels, int garment = -1, int loop = -1,
                        std::uint32_t continuing = kNone);
  // The nearest border vertex to a world point within `reach` (a Phantom's pen picking a seam).
  BorderHit border_near(const Vec3& at, double reach);
  bool seam_mode() const;
  double tool_float(const char* name, double fallback) const;
  void build_overlay(const SceneFrame& frame, Overlay& overlay, std::vector<std::pair<Vec3, QString>>& labels);
  void follow_phantom(const SceneFrame& frame);
  void say(const QString& text);

  Studio& studio_;
  OrbitCamera camera_;
  DrawOptions options_;
  SceneRenderer renderer_;
  QString gl_error_;
  bool gl_ready_ = false;
  QWidget* container_ = nullptr;
  QTimer timer_;
  bool continuous_ = false;
  std::uint64_t drawn_frame_ = 0;
  std::shared_ptr<const PeerView> drawn_peers_;  // a new copy of the peers is a new pointer: draw again
  bool dirty_ = true;
  bool framed_once_ = false;
  // A box to frame once the view has its size (framing needs the view's aspect).
  std::optional<Box3> pending_frame_;
  bool cursor_inside_ = false;  // a mouse's pointer is drawn only while the cursor is over the view

  Drag drag_ = Drag::None;
  QPointF last_, pressed_at_, cursor_;
  bool moved_ = false;
  std::uint32_t buttons_ = 0;
  Vec3 plane_point_{0, 1, 0};  // the working plane, facing the camera
  bool has_plane_ = false;

  ShapeCache shapes_;
  SeamPicker seams_;
  bool picking_ = false;
  std::uint32_t phantom_buttons_ = 0;
  Selection selection_;
  std::vector<Vec3> trail_;
  bool trail_live_ = false;
  std::uint32_t sewn_vertex_ = kNone;  // the border vertex a sew stroke drags
  std::optional<Vec3> drop_;
  std::optional<SewTarget> sew_target_;
  QString hint_;

  QElapsedTimer fps_clock_;
  std::deque<qint64> frame_times_;
  double fps_ = 0;
  std::uint64_t frames_drawn_ = 0;
};

}  // namespace kiji::studio
