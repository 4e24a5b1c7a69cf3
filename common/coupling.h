/* coupling.h — which hydrodynamic coupling each body gets (rigid.coupling).
 *
 * One rule, used by the fluid (force averaging per sphere), the rigid
 * component (whether it uses a sphere's drag coefficients) and `coupler
 * check` (which says what was chosen and why), so the three never disagree.
 * README "Coupling" and models/README.md (`rigid.coupling`) explain it. */
#ifndef COMMON_COUPLING_H
#define COMMON_COUPLING_H

#include "scene.h"

/* Bodies whose explicit feedback number kappa is at least this get the
 * implicit coupling with force averaging under rigid.coupling: auto. */
#define COUPLING_AUTO_KAPPA 0.025

typedef struct {
    coupling_t coupling; /* COUPLING_EXPLICIT or COUPLING_IMPLICIT, never AUTO */
    int averaging;       /* the fluid averages this body's sphere loads over two steps */
    double kappa;        /* explicit feedback number h zeta / m (estimate, see coupling.c) */
} body_coupling_t;

/* The coupling of body b (fixed and prescribed bodies: explicit, no averaging). */
body_coupling_t coupling_of_body(const scene_t *s, int b);

/* The estimate of -dF/dv of a sphere of radius r_cells (lattice units, fluid
 * density 1) that kappa is built from. */
double coupling_drag_estimate(double r_cells);

/* A sentence on the choice for body b, e.g. for `coupler check`. */
void coupling_describe(const scene_t *s, int b, char *buf, size_t size);

#endif
