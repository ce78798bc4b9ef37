#include "app/gui/mesh_view.h"

#include <QMouseEvent>
#include <QWheelEvent>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

namespace ld::gui {

namespace {

const RenderMesh kEmpty;

// A convex polygon extruded by +-half along `side`: a closed prism, outward-facing.
void addPrism(RenderMesh& m, const std::vector<QVector3D>& polygon, const QVector3D& side) {
  const auto base = static_cast<std::uint32_t>(m.positions.size());
  const auto n = static_cast<std::uint32_t>(polygon.size());
  QVector3D centre;
  for (const auto& p : polygon) centre += p;
  centre /= static_cast<float>(n);
  for (float s : {1.0F, -1.0F})
    for (const auto& p : polygon) {
      const QVector3D q = p + s * side;
      m.positions.push_back({q.x(), q.y(), q.z()});
    }
  auto at = [&](std::uint32_t i) {
    const auto& p = m.positions[i];
    return QVector3D(p[0], p[1], p[2]);
  };
  auto tri = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    const QVector3D nrm = QVector3D::crossProduct(at(b) - at(a), at(c) - at(a));
    const QVector3D mid = (at(a) + at(b) + at(c)) / 3.0F;
    if (QVector3D::dotProduct(nrm, mid - centre) < 0) std::swap(b, c);
    m.triangles.push_back({a, b, c});
  };
  for (std::uint32_t i = 1; i + 1 < n; ++i) {
    tri(base, base + i, base + i + 1);
    tri(base + n, base + n + i, base + n + i + 1);
  }
  for (std::uint32_t i = 0; i < n; ++i) {
    const std::uint32_t j = (i + 1) % n;
    tri(base + i, base + j, base + n + j);
    tri(base + i, base + n + j, base + n + i);
  }
}

}  // namespace

RenderMesh scalpelMesh(const ScalpelPose& pose, int* bladeTriangles) {
  const QVector3D d = pose.dir.normalized(), u = pose.up.normalized();
  const QVector3D s = QVector3D::crossProduct(d, u).normalized();
  const QVector3D tip = pose.tip, top = pose.tip - 20.0F * d;
  RenderMesh m;
  // Blade: the cutting edge tip -> top faces `up`; the spine lies 5 mm behind it.
  addPrism(m, {tip, top, top - 5.0F * u, tip - 4.0F * u - 3.0F * d}, 0.15F * s);
  if (bladeTriangles) *bladeTriangles = static_cast<int>(m.triangles.size());
  // Handle: a bar continuing the blade away from the tissue.
  const QVector3D h0 = top - 1.0F * u, h1 = top - 4.0F * u;
  addPrism(m, {h0, h0 - 40.0F * d, h1 - 40.0F * d, h1}, 0.6F * s);
  m.faceKind.assign(m.triangles.size(), 0);
  return m;
}

MeshView::MeshView(QWidget* parent) : QOpenGLWidget(parent) {
  setFocusPolicy(Qt::StrongFocus);
  setMinimumSize(320, 240);
  setMouseTracking(true);  // the scalpel follows the cursor in cut mode
}

MeshView::~MeshView() {
  if (!isValid()) return;
  makeCurrent();
  releaseGl();
  program_.reset();
  doneCurrent();
}

void MeshView::releaseGl() {
  auto drop = [](std::unique_ptr<GlMesh>& g) {
    if (!g) return;
    g->vbo.destroy();
    if (g->vao) g->vao->destroy();
    g.reset();
  };
  for (auto& g : gl_) drop(g);
  gl_.clear();
  drop(previewGl_);
  drop(scalpelGl_);
}

const RenderMesh& MeshView::mesh() const { return objects_.empty() ? kEmpty : objects_.front(); }

void MeshView::setMesh(RenderMesh mesh, bool refit) {
  std::vector<RenderMesh> one;
  one.push_back(std::move(mesh));
  setObjects(std::move(one), refit);
}

void MeshView::setObjects(std::vector<RenderMesh> objects, bool refit) {
  objects_ = std::move(objects);
  for (auto& g : gl_)
    if (g) g->dirty = true;
  if (refit) fitToView();
  update();
}

void MeshView::updatePositions(std::size_t object, const std::vector<Vec3f>& positions) {
  if (object >= objects_.size() || positions.size() != objects_[object].positions.size()) return;
  objects_[object].positions = positions;
  if (object < gl_.size() && gl_[object]) gl_[object]->dirty = true;
  update();
}

void MeshView::setPreview(std::vector<std::array<Vec3f, 3>> fromToDepth) {
  if (fromToDepth.empty() && preview_.empty()) return;
  preview_ = std::move(fromToDepth);
  overlayDirty_ = true;
  update();
}

void MeshView::setScalpel(std::optional<ScalpelPose> pose) {
  if (!pose && !scalpel_) return;
  scalpel_ = pose;
  overlayDirty_ = true;
  update();
}

QPointF MeshView::project(const QVector3D& world) const {
  const QVector3D ndc = camera_.projection(aspect()).map(camera_.view().map(world));
  return {(ndc.x() + 1.0F) * 0.5F * static_cast<float>(width()),
          (1.0F - ndc.y()) * 0.5F * static_cast<float>(height())};
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
  // Every object: pieces moved away stay in the picture.
  Bounds all;
  bool any = false;
  for (const auto& o : objects_) {
    if (o.empty()) continue;
    const Bounds b = o.bounds();
    for (std::size_t a = 0; a < 3; ++a) {
      all.min[a] = any ? std::min(all.min[a], b.min[a]) : b.min[a];
      all.max[a] = any ? std::max(all.max[a], b.max[a]) : b.max[a];
    }
    any = true;
  }
  if (!any) return;
  camera_.fit(QVector3D(all.min[0], all.min[1], all.min[2]), QVector3D(all.max[0], all.max[1], all.max[2]), aspect());
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

  glEnable(GL_DEPTH_TEST);
  glClearColor(0.15F, 0.17F, 0.21F, 1.0F);
  for (auto& g : gl_)
    if (g) g->dirty = true;
  overlayDirty_ = true;
  emit glReady(rendererInfo_);
}

void MeshView::resizeGL(int, int) {}

void MeshView::upload(GlMesh& gl, const std::vector<float>& corners) {
  if (!gl.vao) {
    gl.vao = std::make_unique<QOpenGLVertexArrayObject>();
    gl.vao->create();
    gl.vbo.create();
    gl.vbo.setUsagePattern(QOpenGLBuffer::DynamicDraw);
  }
  gl.count = static_cast<int>(corners.size() / kFloatsPerCorner);
  gl.vao->bind();
  gl.vbo.bind();
  gl.vbo.allocate(corners.data(), static_cast<int>(corners.size() * sizeof(float)));
  constexpr int stride = kFloatsPerCorner * sizeof(float);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(3 * sizeof(float)));
  glEnableVertexAttribArray(2);  // face kind: surface or cut wall
  glVertexAttribPointer(2, 1, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<const void*>(6 * sizeof(float)));
  gl.vao->release();
  gl.dirty = false;
}

void MeshView::paintGL() {
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  if (objects_.empty() || !program_ || !program_->isLinked()) return;
  // One set of buffers per object: a piece that moves uploads only itself.
  if (gl_.size() > objects_.size()) {
    for (std::size_t i = objects_.size(); i < gl_.size(); ++i)
      if (gl_[i]) {
        gl_[i]->vbo.destroy();
        gl_[i]->vao->destroy();
      }
    gl_.resize(objects_.size());
  }
  while (gl_.size() < objects_.size()) gl_.push_back(std::make_unique<GlMesh>());
  for (std::size_t i = 0; i < objects_.size(); ++i)
    if (gl_[i]->dirty) upload(*gl_[i], buildCornerBuffer(objects_[i]));
  if (overlayDirty_) {
    if (!previewGl_) previewGl_ = std::make_unique<GlMesh>();
    if (!scalpelGl_) scalpelGl_ = std::make_unique<GlMesh>();
    std::vector<float> lines;
    for (const auto& p : preview_)
      for (const auto* q : {&p[0], &p[1], &p[1], &p[2]})
        lines.insert(lines.end(), {(*q)[0], (*q)[1], (*q)[2], 0.0F, 0.0F, 1.0F, 1.0F});
    upload(*previewGl_, lines);
    int bladeTriangles = 0;
    upload(*scalpelGl_,
           scalpel_ ? buildCornerBuffer(scalpelMesh(*scalpel_, &bladeTriangles), 30.0F) : std::vector<float>{});
    bladeCorners_ = 3 * bladeTriangles;
    overlayDirty_ = false;
  }

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
  program_->setUniformValue("uTissueColor", QVector3D(kTissueColor[0], kTissueColor[1], kTissueColor[2]));
  program_->setUniformValue("uInteriorColor", QVector3D(kInteriorColor[0], kInteriorColor[1], kInteriorColor[2]));

  for (const auto& g : gl_) {
    g->vao->bind();
    program_->setUniformValue("uWire", false);
    // Push the surface back a little so the wireframe overlay is not buried in it.
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1.0F, 1.0F);
    glDrawArrays(GL_TRIANGLES, 0, g->count);
    glDisable(GL_POLYGON_OFFSET_FILL);
    if (wireframe_) {
      program_->setUniformValue("uWire", true);
      glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
      glDrawArrays(GL_TRIANGLES, 0, g->count);
      glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    }
    g->vao->release();
  }

  if (scalpelGl_ && scalpelGl_->count > 0) {
    scalpelGl_->vao->bind();
    program_->setUniformValue("uWire", false);
    program_->setUniformValue("uShininess", 60.0F);
    program_->setUniformValue("uTissueColor", QVector3D(kBladeColor[0], kBladeColor[1], kBladeColor[2]));
    glDrawArrays(GL_TRIANGLES, 0, bladeCorners_);
    program_->setUniformValue("uTissueColor", QVector3D(kHandleColor[0], kHandleColor[1], kHandleColor[2]));
    glDrawArrays(GL_TRIANGLES, bladeCorners_, scalpelGl_->count - bladeCorners_);
    scalpelGl_->vao->release();
  }
  if (previewGl_ && previewGl_->count > 0) {
    // The cut inside the current triangle: over the surface, so it shows at once.
    previewGl_->vao->bind();
    program_->setUniformValue("uWire", true);
    program_->setUniformValue("uWireColor", QVector3D(0.35F, 0.02F, 0.06F));
    glDisable(GL_DEPTH_TEST);
    glLineWidth(3.0F);
    glDrawArrays(GL_LINES, 0, previewGl_->count);
    glLineWidth(1.0F);
    glEnable(GL_DEPTH_TEST);
    previewGl_->vao->release();
  }
  program_->release();
}

std::optional<PickHit> MeshView::pick(const QPointF& windowPos) const {
  const QVector3D origin = camera_.eye();
  const QVector3D dir = camera_.rayDirection(static_cast<float>(windowPos.x()), static_cast<float>(windowPos.y()),
                                             static_cast<float>(width()), static_cast<float>(height()));
  std::optional<PickHit> best;
  // Moller-Trumbore against every triangle of every object: a pick happens once per
  // press or mouse move.
  for (std::size_t o = 0; o < objects_.size(); ++o) {
    const RenderMesh& m = objects_[o];
    for (std::size_t f = 0; f < m.triangles.size(); ++f) {
      const auto& t = m.triangles[f];
      const auto& pa = m.positions[t[0]];
      const auto& pb = m.positions[t[1]];
      const auto& pc = m.positions[t[2]];
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
      h.object = o;
      h.face = static_cast<std::uint32_t>(f);
      h.point = origin + dist * dir;
      h.distance = dist;
      h.normal = QVector3D::crossProduct(e1, e2).normalized();
      const float w0 = 1.0F - u - v;
      h.vertex = (w0 >= u && w0 >= v) ? t[0] : (u >= v ? t[1] : t[2]);
      best = h;
    }
  }
  return best;
}

std::optional<QVector3D> MeshView::onPlane(const QPointF& windowPos, const QVector3D& point,
                                           const QVector3D& normal) const {
  const QVector3D origin = camera_.eye();
  const QVector3D dir = camera_.rayDirection(static_cast<float>(windowPos.x()), static_cast<float>(windowPos.y()),
                                             static_cast<float>(width()), static_cast<float>(height()));
  const float denom = QVector3D::dotProduct(dir, normal);
  if (std::abs(denom) < 1e-6F) return std::nullopt;
  const float t = QVector3D::dotProduct(point - origin, normal) / denom;
  if (t <= 0.0F) return std::nullopt;
  return origin + t * dir;
}

std::optional<QVector3D> MeshView::dragPoint(const QPointF& windowPos, const QVector3D& through) const {
  return onPlane(windowPos, through, camera_.forward());
}

void MeshView::updateScalpelAt(const QVector3D& surface, const QVector3D& normal, const QVector3D& motion) {
  ScalpelPose pose;
  pose.dir = -normal.normalized();
  pose.tip = surface + static_cast<float>(cutDepth_) * pose.dir;
  // The sharp side faces the motion; at rest, the screen's right.
  QVector3D up = motion.lengthSquared() > 1e-8F ? motion : camera_.right();
  up -= QVector3D::dotProduct(up, pose.dir) * pose.dir;
  if (up.lengthSquared() < 1e-8F) up = QVector3D::crossProduct(pose.dir, QVector3D(1, 0, 0));
  pose.up = up.normalized();
  setScalpel(pose);
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
      cutLast_ = hit->point;
      updateScalpelAt(hit->point, hit->normal, {});
      emit cutStarted(hit->point, hit->normal);
    } else {
      drag_ = Drag::None;
    }
    return;
  }
  if (pushEnabled_ && plainLeft && leftDrag_ == LeftDrag::Grasp) {
    const auto hit = pick(e->position());
    if (hit && hit->object > 0) {  // only pieces cut free move; the tissue is held
      drag_ = Drag::Grasp;
      pushPoint_ = hit->point;
      emit graspStarted(hit->object, hit->point);
    } else {
      drag_ = Drag::None;
    }
    return;
  }
  if (pushGesture) {
    if (const auto hit = pick(e->position())) {
      drag_ = Drag::Push;
      pushPoint_ = hit->point;
      emit pushStarted(hit->object, hit->vertex, hit->point);
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
  if (drag_ == Drag::Grasp) {
    // The piece moves in the plane facing the camera through the grasped point.
    if (const auto target = dragPoint(e->position(), pushPoint_)) emit graspMoved(*target);
    return;
  }
  if (drag_ == Drag::Cut) {
    // Follow the cursor on the tangent plane where the stroke began.
    if (const auto q = onPlane(e->position(), pushPoint_, cutNormal_)) {
      updateScalpelAt(*q, cutNormal_, *q - cutLast_);
      cutLast_ = *q;
      emit cutMoved(*q);
    }
    return;
  }
  if (drag_ == Drag::None) {
    // Hovering in cut mode: the scalpel stands at the cursor at the set depth.
    if (pushEnabled_ && leftDrag_ == LeftDrag::Cut) {
      if (const auto hit = pick(e->position()))
        updateScalpelAt(hit->point, hit->normal, {});
      else
        setScalpel(std::nullopt);
    }
    return;
  }
  if (drag_ == Drag::Orbit)
    camera_.orbit(static_cast<float>(d.x()), static_cast<float>(d.y()));
  else if (drag_ == Drag::Pan)
    camera_.pan(static_cast<float>(d.x()), static_cast<float>(d.y()), static_cast<float>(height()));
  update();
}

void MeshView::mouseReleaseEvent(QMouseEvent*) {
  if (drag_ == Drag::Push) emit pushEnded();
  if (drag_ == Drag::Cut) emit cutEnded();
  if (drag_ == Drag::Grasp) emit graspEnded();
  drag_ = Drag::None;
}

void MeshView::mouseDoubleClickEvent(QMouseEvent*) { fitToView(); }

void MeshView::wheelEvent(QWheelEvent* e) {
  camera_.zoom(static_cast<float>(e->angleDelta().y()) / 120.0F);
  update();
}

}  // namespace ld::gui
