#pragma once
// Order statistics for the dashboards.
#include <vector>

#include "database/store.h"

namespace ld::db {

// Count, min, max and quartiles (linear interpolation between order statistics, as R's
// type 7 and numpy's default). Sorts `values`. Empty input gives n = 0 and zeros.
Summary summarize(std::vector<double> values);

}  // namespace ld::db
