#pragma once
// An orbit camera around a target point with z up: yaw and pitch place the eye on a
// sphere of radius `distance`. Mouse gestures map to orbit, pan and zoom; fit() frames
// a bounding box.
#include <QMatrix4x4>
#include <QVector3D>

namespace ld::gui {

class OrbitCamera {
 public:
  [[nodiscard]] QVector3D target() const { return target_; }
  [[nodiscard]] float distance() const { return distance_; }
  [[nodiscard]] float yawDegrees() const { return yaw_; }
  [[nodiscard]] float pitchDegrees() const { return pitch_; }
  [[nodiscard]] float fovYDegrees() const { return fovY_; }
  [[nodiscard]] QVector3D eye() const;
  [[nodiscard]] QVector3D forward() const;  // unit, from the eye to the target
  [[nodiscard]] QVector3D right() const;    // unit, screen x
  [[nodiscard]] QVector3D up() const;       // unit, screen y

  [[nodiscard]] QMatrix4x4 view() const;
  [[nodiscard]] QMatrix4x4 projection(float aspect) const;

  // Drags in pixels: orbit turns 0.4 degrees per pixel; pan moves the target so the
  // point under the cursor follows it (viewport height in pixels).
  void orbit(float dxPixels, float dyPixels);
  void pan(float dxPixels, float dyPixels, float viewportHeight);
  // Positive steps zoom in; one step changes the distance by 15 %.
  void zoom(float steps);
  // Looks at the box's centre from the current direction, close enough that the
  // box's bounding sphere fits the narrower field of view.
  void fit(const QVector3D& min, const QVector3D& max, float aspect);
  void setOrientation(float yawDegrees, float pitchDegrees);
  // Unit ray through a window point (pixels, y down) for picking.
  [[nodiscard]] QVector3D rayDirection(float x, float y, float width, float height) const;

 private:
  QVector3D target_{0, 0, 0};
  float distance_ = 150.0F;
  float yaw_ = -90.0F;   // eye on the -y side
  float pitch_ = 50.0F;  // looking down on the tissue
  float fovY_ = 35.0F;
  float sceneRadius_ = 50.0F;
};

}  // namespace ld::gui
