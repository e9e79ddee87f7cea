#include "krr_core/common/format.h"

#include <sstream>

namespace krr {

std::string formatNumber(double v, int precision) {
  std::ostringstream o;
  o.precision(precision);
  o << v;
  return o.str();
}

}  // namespace krr
