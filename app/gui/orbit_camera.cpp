#include "app/gui/orbit_camera.h"

#include <algorithm>
#include <cmath>

namespace ld::gui {
namespace {
constexpr float kDegToRad = 3.14159265F / 180.0F;
}

QVector3D OrbitCamera::forward() const {
  const float y = yaw_ * kDegToRad, p = pitch_ * kDegToRad;
  return -QVector3D(std::cos(p) * std::cos(y), std::cos(p) * std::sin(y), std::sin(p));
}

QVector3D OrbitCamera::eye() const { return target_ - distance_ * forward(); }

QVector3D OrbitCamera::right() const { return QVector3D::crossProduct(forward(), QVector3D(0, 0, 1)).normalized(); }

QVector3D OrbitCamera::up() const { return QVector3D::crossProduct(right(), forward()).normalized(); }

QMatrix4x4 OrbitCamera::view() const {
  QMatrix4x4 m;
  m.lookAt(eye(), target_, up());
  return m;
}

QMatrix4x4 OrbitCamera::projection(float aspect) const {
  // Near and far planes follow the scene so depth precision is not wasted.
  const float nearPlane = std::max(0.01F * sceneRadius_, distance_ - 4.0F * sceneRadius_);
  const float farPlane = distance_ + 4.0F * sceneRadius_;
  QMatrix4x4 m;
  m.perspective(fovY_, std::max(aspect, 1e-3F), nearPlane, farPlane);
  return m;
}

void OrbitCamera::orbit(float dxPixels, float dyPixels) {
  yaw_ = std::fmod(yaw_ - 0.4F * dxPixels, 360.0F);
  pitch_ = std::clamp(pitch_ + 0.4F * dyPixels, -89.0F, 89.0F);
}

void OrbitCamera::pan(float dxPixels, float dyPixels, float viewportHeight) {
  // World size of one pixel at the target's depth.
  const float perPixel = 2.0F * distance_ * std::tan(0.5F * fovY_ * kDegToRad) / std::max(viewportHeight, 1.0F);
  target_ += perPixel * (-dxPixels * right() + dyPixels * up());
}

void OrbitCamera::zoom(float steps) { distance_ = std::clamp(distance_ * std::pow(0.85F, steps), 1e-3F, 1e6F); }

void OrbitCamera::fit(const QVector3D& min, const QVector3D& max, float aspect) {
  target_ = 0.5F * (min + max);
  sceneRadius_ = std::max(0.5F * (max - min).length(), 1e-3F);
  const float halfY = 0.5F * fovY_ * kDegToRad;
  const float halfX = std::atan(std::tan(halfY) * std::max(aspect, 1e-3F));
  distance_ = 1.05F * sceneRadius_ / std::sin(std::min(halfX, halfY));
}

void OrbitCamera::setOrientation(float yawDegrees, float pitchDegrees) {
  yaw_ = yawDegrees;
  pitch_ = std::clamp(pitchDegrees, -89.0F, 89.0F);
}

QVector3D OrbitCamera::rayDirection(float x, float y, float width, float height) const {
  const float t = std::tan(0.5F * fovY_ * kDegToRad);
  const float nx = (2.0F * x / std::max(width, 1.0F) - 1.0F) * t * width / std::max(height, 1.0F);
  const float ny = (1.0F - 2.0F * y / std::max(height, 1.0F)) * t;
  return (forward() + nx * right() + ny * up()).normalized();
}

}  // namespace ld::gui
