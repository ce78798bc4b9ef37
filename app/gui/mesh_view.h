#pragma once
// The 3-D view: draws one or more tissue objects (RenderMesh, each with buffers of
// its own) with Phong shading (GLSL 3.3 core), optional wireframe overlay and
// two-sided lighting, the scalpel and the cut's preview, and turns mouse gestures
// into camera motion. Left drag orbits, right or middle drag (or Shift+left) pans, the wheel
// zooms, a double click fits the model to the view. With pushing enabled, Ctrl+left
// drag (or a plain left drag in push mode) grabs the surface point under the cursor
// and reports where the cursor pulls it (pushStarted / pushMoved / pushEnded). In cut
// mode the scalpel follows the cursor at the set depth; in grasp mode a left drag
// picks a tissue object and reports where the cursor moves it.
#include <QOpenGLBuffer>
#include <QOpenGLFunctions_3_3_Core>
#include <QOpenGLShaderProgram>
#include <QOpenGLVertexArrayObject>
#include <QOpenGLWidget>
#include <QPoint>

#include <array>
#include <cstdint>
#include <memory>
#include <optional>

#include "app/gui/orbit_camera.h"
#include "app/gui/render_mesh.h"

namespace ld::gui {

struct PickHit {
  std::size_t object = 0;  // index into objects()
  std::uint32_t face = 0;
  std::uint32_t vertex = 0;  // the face's corner nearest the hit
  QVector3D point;
  QVector3D normal;    // the face's unit normal
  float distance = 0;  // along the ray from the eye
};

// What a plain left drag does.
enum class LeftDrag { Orbit, Push, Cut, Grasp };

// The scalpel as drawn (DESIGN.md geometry): edge from tip to tip - 20 dir, sharp side up.
struct ScalpelPose {
  QVector3D tip, dir, up;
};

class MeshView : public QOpenGLWidget, protected QOpenGLFunctions_3_3_Core {
  Q_OBJECT

 public:
  explicit MeshView(QWidget* parent = nullptr);
  ~MeshView() override;

  // Shows `mesh`; the camera is fitted to it when `refit`.
  void setMesh(RenderMesh mesh, bool refit = true);
  // Same triangles, moved vertices (for a deforming tissue).
  void updatePositions(const std::vector<Vec3f>& positions) { updatePositions(0, positions); }
  void updatePositions(std::size_t object, const std::vector<Vec3f>& positions);
  // Several objects (the tissue and the pieces cut free from it).
  void setObjects(std::vector<RenderMesh> objects, bool refit = false);
  [[nodiscard]] const std::vector<RenderMesh>& objects() const { return objects_; }
  // The first object (the tissue as loaded).
  [[nodiscard]] const RenderMesh& mesh() const;
  // The cut's temporary segments (drawn over the surface) and the scalpel.
  void setPreview(std::vector<std::array<Vec3f, 3>> fromToDepth);
  [[nodiscard]] const std::vector<std::array<Vec3f, 3>>& preview() const { return preview_; }
  void setScalpel(std::optional<ScalpelPose> pose);
  [[nodiscard]] const std::optional<ScalpelPose>& scalpel() const { return scalpel_; }
  void setCutDepth(double mm) { cutDepth_ = mm; }
  [[nodiscard]] double cutDepth() const { return cutDepth_; }
  // Window position (pixels, y down) of a world point.
  [[nodiscard]] QPointF project(const QVector3D& world) const;

  // The nearest front triangle under a window point (pixels), if any.
  [[nodiscard]] std::optional<PickHit> pick(const QPointF& windowPos) const;
  // Where the cursor at windowPos meets the plane through `through` facing the camera.
  [[nodiscard]] std::optional<QVector3D> dragPoint(const QPointF& windowPos, const QVector3D& through) const;

  [[nodiscard]] bool wireframe() const { return wireframe_; }
  [[nodiscard]] bool twoSided() const { return twoSided_; }
  [[nodiscard]] OrbitCamera& camera() { return camera_; }
  [[nodiscard]] QString rendererInfo() const { return rendererInfo_; }
  [[nodiscard]] QSize sizeHint() const override { return {1024, 720}; }

  static constexpr float kTissueColor[3] = {0.86F, 0.42F, 0.40F};
  static constexpr float kInteriorColor[3] = {0.72F, 0.14F, 0.22F};
  static constexpr float kBladeColor[3] = {0.78F, 0.80F, 0.84F};
  static constexpr float kHandleColor[3] = {0.30F, 0.45F, 0.60F};

 public slots:
  void setWireframe(bool on);
  void setTwoSided(bool on);
  void fitToView();
  void resetView();
  void setPushEnabled(bool on) { pushEnabled_ = on; }
  void setLeftDrag(LeftDrag mode) {
    leftDrag_ = mode;
    if (mode != LeftDrag::Cut) setScalpel(std::nullopt);
  }
  [[nodiscard]] LeftDrag leftDrag() const { return leftDrag_; }

 signals:
  void glReady(const QString& rendererInfo);
  void pushStarted(std::size_t object, std::uint32_t vertex, const QVector3D& point);
  void pushMoved(const QVector3D& target);
  void pushEnded();
  // A scalpel stroke: the surface point and normal where it starts, then points on
  // the plane through that point (with that normal) under the cursor.
  void cutStarted(const QVector3D& point, const QVector3D& normal);
  void cutMoved(const QVector3D& point);
  void cutEnded();
  // Grasp mode: the object picked, then where the grasped point should go.
  void graspStarted(std::size_t object, const QVector3D& point);
  void graspMoved(const QVector3D& target);
  void graspEnded();

 protected:
  void initializeGL() override;
  void resizeGL(int w, int h) override;
  void paintGL() override;
  void mousePressEvent(QMouseEvent* e) override;
  void mouseMoveEvent(QMouseEvent* e) override;
  void mouseReleaseEvent(QMouseEvent* e) override;
  void mouseDoubleClickEvent(QMouseEvent* e) override;
  void wheelEvent(QWheelEvent* e) override;

 private:
  enum class Drag { None, Orbit, Pan, Push, Cut, Grasp };
  struct GlMesh {
    std::unique_ptr<QOpenGLVertexArrayObject> vao;
    QOpenGLBuffer vbo{QOpenGLBuffer::VertexBuffer};
    int count = 0;
    bool dirty = true;
  };
  void upload(GlMesh& gl, const std::vector<float>& corners);
  void releaseGl();
  [[nodiscard]] float aspect() const;
  void updateScalpelAt(const QVector3D& surface, const QVector3D& normal, const QVector3D& motion);
  [[nodiscard]] std::optional<QVector3D> onPlane(const QPointF& windowPos, const QVector3D& point,
                                                 const QVector3D& normal) const;

  std::vector<RenderMesh> objects_;
  std::vector<std::unique_ptr<GlMesh>> gl_;
  std::vector<std::array<Vec3f, 3>> preview_;
  std::optional<ScalpelPose> scalpel_;
  double cutDepth_ = 2.0;
  std::unique_ptr<GlMesh> previewGl_, scalpelGl_;
  int bladeCorners_ = 0;
  bool overlayDirty_ = true;
  bool wireframe_ = false;
  bool twoSided_ = true;
  OrbitCamera camera_;
  Drag drag_ = Drag::None;
  QPoint lastMouse_;
  bool pushEnabled_ = false;
  LeftDrag leftDrag_ = LeftDrag::Orbit;
  QVector3D pushPoint_;
  QVector3D cutNormal_, cutLast_;
  QString rendererInfo_;

  std::unique_ptr<QOpenGLShaderProgram> program_;
};

// The scalpel as triangles (blade first, `bladeCorners` corners, then the handle).
RenderMesh scalpelMesh(const ScalpelPose& pose, int* bladeTriangles = nullptr);

}  // namespace ld::gui
