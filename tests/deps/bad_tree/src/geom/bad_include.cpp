// A deliberate violation: geom may not include io (checked by deps.include_rules_catch).
#include "io/png.hpp"
