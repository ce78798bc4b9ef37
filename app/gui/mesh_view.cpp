#include "app/gui/mesh_view.h"

#include <QMouseEvent>
#include <QWheelEvent>

#include <cmath>
#include <stdexcept>

namespace ld::gui {

MeshView::MeshView(QWidget* parent) : QOpenGLWidget(parent) {
  setFocusPolicy(Qt::StrongFocus);
  setMinimumSize(320, 240);
}

MeshView::~MeshView() {
  if (!isValid()) return;
  makeCurrent();
  vbo_.destroy();
  vao_.destroy();
  program_.reset();
  doneCurrent();
}

void MeshView::setMesh(RenderMesh mesh, bool refit) {
  mesh_ = std::move(mesh);
  dirty_ = true;
  if (refit) fitToView();
  update();
}

void MeshView::updatePositions(const std::vector<Vec3f>& positions) {
  if (positions.size() != mesh_.positions.size()) return;
  mesh_.positions = positions;
  dirty_ = true;
  update();
}

void MeshView::setWireframe(bool on) {
  wireframe_ = on;
  update();
}

void MeshView::setTwoSided(bool on) {
  twoSided_ = on;
  update();
}

float MeshView::aspect() const {
  return height() > 0 ? static_cast<float>(width()) / static_cast<float>(height()) : 1.0F;
}

void MeshView::fitToView() {
  if (mesh_.empty()) return;
  const Bounds b = mesh_.bounds();
  camera_.fit(QVector3D(b.min[0], b.min[1], b.min[2]), QVector3D(b.max[0], b.max[1], b.max[2]), aspect());
  update();
}

void MeshView::resetView() {
  camera_.setOrientation(-90.0F, 50.0F);
  fitToView();
}

void MeshView::initializeGL() {
  initializeOpenGLFunctions();
  const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  const auto* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
  rendererInfo_ = QStringLiteral("%1, OpenGL %2").arg(renderer ? renderer : "?", version ? version : "?");

  program_ = std::make_unique<QOpenGLShaderProgram>();
  if (!program_->addShaderFromSourceFile(QOpenGLShader::Vertex, QStringLiteral(":/shaders/phong.vert")) ||
      !program_->addShaderFromSourceFile(QOpenGLShader::Fragment, QStringLiteral(":/shaders/phong.frag")) ||
      !program_->link())
    qCritical("lapdissect: shader build failed: %s", qPrintable(program_->log()));

  vao_.create();
  vbo_.create();
  vbo_.setUsagePattern(QOpenGLBuffer::DynamicDraw);
  glEnable(GL_DEPTH_TEST);
  glClearColor(0.15F, 0.17F, 0.21F, 1.0F);
  dirty_ = true;
  emit glReady(rendererInfo_);
}

void MeshView::resizeGL(int, int) {}

void MeshView::upload() {
  const std::vector<float> corners = buildCornerBuffer(mesh_);
  cornerCount_ = static_cast<int>(corners.size() / kFloatsPerCorner);
  vao_.bind();
  vbo_.bind();
  vbo_.allocate(corners.data(), static_cast<int>(corners.size() * sizeof(float)));
  constexpr int stride = kFloatsPerCorner * sizeof(float);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(3 * sizeof(float)));
  glEnableVertexAttribArray(2);  // face kind: surface or cut wall
  glVertexAttribPointer(2, 1, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(6 * sizeof(float)));
  vao_.release();
  dirty_ = false;
}

void MeshView::paintGL() {
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  if (mesh_.empty() || !program_ || !program_->isLinked()) return;
  if (dirty_) upload();

  const QMatrix4x4 view = camera_.view();
  program_->bind();
  program_->setUniformValue("uModelView", view);
  program_->setUniformValue("uProjection", camera_.projection(aspect()));
  program_->setUniformValue("uNormalMatrix", view.normalMatrix());
  program_->setUniformValue("uTwoSided", twoSided_);
  program_->setUniformValue("uBackColor", QVector3D(kInteriorColor[0], kInteriorColor[1], kInteriorColor[2]));
  program_->setUniformValue("uWireColor", QVector3D(0.18F, 0.08F, 0.08F));
  program_->setUniformValue("uShininess", 30.0F);
  // Above and to the upper left of the camera, a bit nearer than the target, so a flat
  // tissue shows a gradient and a wet highlight rather than one flat colour.
  const float d = camera_.distance();
  program_->setUniformValue("uKeyLightEye", QVector3D(-0.5F * d, 0.9F * d, -0.4F * d));

  vao_.bind();
  program_->setUniformValue("uTissueColor", QVector3D(kTissueColor[0], kTissueColor[1], kTissueColor[2]));
  program_->setUniformValue("uInteriorColor", QVector3D(kInteriorColor[0], kInteriorColor[1], kInteriorColor[2]));
  program_->setUniformValue("uWire", false);
  // Push the surface back a little so the wireframe overlay is not buried in it.
  glEnable(GL_POLYGON_OFFSET_FILL);
  glPolygonOffset(1.0F, 1.0F);
  glDrawArrays(GL_TRIANGLES, 0, cornerCount_);
  glDisable(GL_POLYGON_OFFSET_FILL);
  if (wireframe_) {
    program_->setUniformValue("uWire", true);
    glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
    glDrawArrays(GL_TRIANGLES, 0, cornerCount_);
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
  }
  vao_.release();
  program_->release();
}

std::optional<PickHit> MeshView::pick(const QPointF& windowPos) const {
  const QVector3D origin = camera_.eye();
  const QVector3D dir = camera_.rayDirection(static_cast<float>(windowPos.x()), static_cast<float>(windowPos.y()),
                                             static_cast<float>(width()), static_cast<float>(height()));
  std::optional<PickHit> best;
  // Moller-Trumbore against every triangle: a pick happens once per press.
  for (std::size_t f = 0; f < mesh_.triangles.size(); ++f) {
    const auto& t = mesh_.triangles[f];
    const auto& pa = mesh_.positions[t[0]];
    const auto& pb = mesh_.positions[t[1]];
    const auto& pc = mesh_.positions[t[2]];
    const QVector3D a(pa[0], pa[1], pa[2]), b(pb[0], pb[1], pb[2]), c(pc[0], pc[1], pc[2]);
    const QVector3D e1 = b - a, e2 = c - a;
    const QVector3D p = QVector3D::crossProduct(dir, e2);
    const float det = QVector3D::dotProduct(e1, p);
    if (std::abs(det) < 1e-12F) continue;
    const float inv = 1.0F / det;
    const QVector3D s = origin - a;
    const float u = QVector3D::dotProduct(s, p) * inv;
    if (u < 0.0F || u > 1.0F) continue;
    const QVector3D q = QVector3D::crossProduct(s, e1);
    const float v = QVector3D::dotProduct(dir, q) * inv;
    if (v < 0.0F || u + v > 1.0F) continue;
    const float dist = QVector3D::dotProduct(e2, q) * inv;
    if (dist <= 0.0F || (best && dist >= best->distance)) continue;
    PickHit h;
    h.face = static_cast<std::uint32_t>(f);
    h.point = origin + dist * dir;
    h.distance = dist;
    h.normal = QVector3D::crossProduct(e1, e2).normalized();
    const float w0 = 1.0F - u - v;
    h.vertex = (w0 >= u && w0 >= v) ? t[0] : (u >= v ? t[1] : t[2]);
    best = h;
  }
  return best;
}

std::optional<QVector3D> MeshView::dragPoint(const QPointF& windowPos, const QVector3D& through) const {
  const QVector3D origin = camera_.eye();
  const QVector3D dir = camera_.rayDirection(static_cast<float>(windowPos.x()), static_cast<float>(windowPos.y()),
                                             static_cast<float>(width()), static_cast<float>(height()));
  const QVector3D n = camera_.forward();
  const float denom = QVector3D::dotProduct(dir, n);
  if (std::abs(denom) < 1e-6F) return std::nullopt;
  const float t = QVector3D::dotProduct(through - origin, n) / denom;
  if (t <= 0.0F) return std::nullopt;
  return origin + t * dir;
}

void MeshView::mousePressEvent(QMouseEvent* e) {
  lastMouse_ = e->position().toPoint();
  const bool plainLeft = e->button() == Qt::LeftButton && !(e->modifiers() & (Qt::ShiftModifier | Qt::ControlModifier));
  const bool pushGesture = pushEnabled_ && e->button() == Qt::LeftButton &&
                           ((e->modifiers() & Qt::ControlModifier) || (plainLeft && leftDrag_ == LeftDrag::Push));
  if (pushEnabled_ && plainLeft && leftDrag_ == LeftDrag::Cut) {
    if (const auto hit = pick(e->position())) {
      drag_ = Drag::Cut;
      pushPoint_ = hit->point;
      cutNormal_ = hit->normal;
      emit cutStarted(hit->point, hit->normal);
    } else {
      drag_ = Drag::None;
    }
    return;
  }
  if (pushGesture) {
    if (const auto hit = pick(e->position())) {
      drag_ = Drag::Push;
      pushPoint_ = hit->point;
      emit pushStarted(hit->vertex, hit->point);
    } else {
      drag_ = Drag::None;
    }
    return;
  }
  const bool pan = e->button() == Qt::RightButton || e->button() == Qt::MiddleButton ||
                   (e->button() == Qt::LeftButton && (e->modifiers() & Qt::ShiftModifier));
  drag_ = pan ? Drag::Pan : (e->button() == Qt::LeftButton ? Drag::Orbit : Drag::None);
}

void MeshView::mouseMoveEvent(QMouseEvent* e) {
  const QPoint p = e->position().toPoint();
  const QPoint d = p - lastMouse_;
  lastMouse_ = p;
  if (drag_ == Drag::Push) {
    if (const auto target = dragPoint(e->position(), pushPoint_)) emit pushMoved(*target);
    return;
  }
  if (drag_ == Drag::Cut) {
    // Follow the cursor on the tangent plane where the stroke began.
    const QVector3D origin = camera_.eye();
    const QVector3D dir =
        camera_.rayDirection(static_cast<float>(e->position().x()), static_cast<float>(e->position().y()),
                             static_cast<float>(width()), static_cast<float>(height()));
    const float denom = QVector3D::dotProduct(dir, cutNormal_);
    if (std::abs(denom) > 1e-6F) {
      const float t = QVector3D::dotProduct(pushPoint_ - origin, cutNormal_) / denom;
      if (t > 0.0F) emit cutMoved(origin + t * dir);
    }
    return;
  }
  if (drag_ == Drag::Orbit)
    camera_.orbit(static_cast<float>(d.x()), static_cast<float>(d.y()));
  else if (drag_ == Drag::Pan)
    camera_.pan(static_cast<float>(d.x()), static_cast<float>(d.y()), static_cast<float>(height()));
  else
    return;
  update();
}

void MeshView::mouseReleaseEvent(QMouseEvent*) {
  if (drag_ == Drag::Push) emit pushEnded();
  if (drag_ == Drag::Cut) emit cutEnded();
  drag_ = Drag::None;
}

void MeshView::mouseDoubleClickEvent(QMouseEvent*) { fitToView(); }

void MeshView::wheelEvent(QWheelEvent* e) {
  camera_.zoom(static_cast<float>(e->angleDelta().y()) / 120.0F);
  update();
}

}  // namespace ld::gui
