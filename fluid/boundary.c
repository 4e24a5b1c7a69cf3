/* boundary.c — coefficients of the curved-wall schemes (boundary.h). */
#include "boundary.h"

const char *const boundary_scheme_names[BOUNDARY_NSCHEMES] = {"bounce_back", "yu", "cli", "quadratic",
                                                               "multireflection"};
