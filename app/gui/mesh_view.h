#pragma once
// The 3-D view: draws a RenderMesh with Phong shading (GLSL 3.3 core), optional
// wireframe overlay and two-sided lighting, and turns mouse gestures into camera
// motion. Left drag orbits, right or middle drag (or Shift+left) pans, the wheel
// zooms, a double click fits the model to the view. With pushing enabled, Ctrl+left
// drag (or a plain left drag in push mode) grabs the surface point under the cursor
// and reports where the cursor pulls it (pushStarted / pushMoved / pushEnded).
#include <QOpenGLBuffer>
#include <QOpenGLFunctions_3_3_Core>
#include <QOpenGLShaderProgram>
#include <QOpenGLVertexArrayObject>
#include <QOpenGLWidget>
#include <QPoint>

#include <cstdint>
#include <memory>
#include <optional>

#include "app/gui/orbit_camera.h"
#include "app/gui/render_mesh.h"

namespace ld::gui {

struct PickHit {
  std::uint32_t face = 0;
  std::uint32_t vertex = 0;  // the face's corner nearest the hit
  QVector3D point;
  QVector3D normal;    // the face's unit normal
  float distance = 0;  // along the ray from the eye
};

// What a plain left drag does.
enum class LeftDrag { Orbit, Push, Cut };

class MeshView : public QOpenGLWidget, protected QOpenGLFunctions_3_3_Core {
  Q_OBJECT

 public:
  explicit MeshView(QWidget* parent = nullptr);
  ~MeshView() override;

  // Shows `mesh`; the camera is fitted to it when `refit`.
  void setMesh(RenderMesh mesh, bool refit = true);
  // Same triangles, moved vertices (for a deforming tissue).
  void updatePositions(const std::vector<Vec3f>& positions);
  [[nodiscard]] const RenderMesh& mesh() const { return mesh_; }

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
  static constexpr float kInteriorColor[3] = {0.62F, 0.16F, 0.20F};

 public slots:
  void setWireframe(bool on);
  void setTwoSided(bool on);
  void fitToView();
  void resetView();
  void setPushEnabled(bool on) { pushEnabled_ = on; }
  void setLeftDrag(LeftDrag mode) { leftDrag_ = mode; }
  [[nodiscard]] LeftDrag leftDrag() const { return leftDrag_; }

 signals:
  void glReady(const QString& rendererInfo);
  void pushStarted(std::uint32_t vertex, const QVector3D& point);
  void pushMoved(const QVector3D& target);
  void pushEnded();
  // A scalpel stroke: the surface point and normal where it starts, then points on
  // the plane through that point (with that normal) under the cursor.
  void cutStarted(const QVector3D& point, const QVector3D& normal);
  void cutMoved(const QVector3D& point);
  void cutEnded();

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
  enum class Drag { None, Orbit, Pan, Push, Cut };
  void upload();
  [[nodiscard]] float aspect() const;

  RenderMesh mesh_;
  bool dirty_ = false;
  bool wireframe_ = false;
  bool twoSided_ = true;
  OrbitCamera camera_;
  Drag drag_ = Drag::None;
  QPoint lastMouse_;
  bool pushEnabled_ = false;
  LeftDrag leftDrag_ = LeftDrag::Orbit;
  QVector3D pushPoint_;
  QVector3D cutNormal_;
  QString rendererInfo_;

  std::unique_ptr<QOpenGLShaderProgram> program_;
  QOpenGLVertexArrayObject vao_;
  QOpenGLBuffer vbo_{QOpenGLBuffer::VertexBuffer};
  int cornerCount_ = 0;
};

}  // namespace ld::gui
