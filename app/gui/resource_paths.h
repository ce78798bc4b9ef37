#pragma once
// Where the bundled resources (models, tasks, shaders) are: $LD_RESOURCES, next to
// the binary (resources/, ../resources, ../share/lapdissect/resources), then the
// source tree's resources folder known at build time.
#include <QString>

namespace ld::gui {

// The first candidate folder that holds models/tissue_slab.obj, or an empty string.
QString findResourcesDir();
QString defaultModelPath();  // <resources>/models/tissue_slab.obj, or empty

}  // namespace ld::gui
