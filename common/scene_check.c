/* scene_check.c — why a scene is refused.
 *
 * The checks of single values (a number written as a whole, a range, a
 * finite vector, a whole number) and of the scene's physical consistency: a
 * resolution whose step dt is a usable number, the domain a whole number of
 * cells, spheres resolved and inside the domain, no overlap between bodies at
 * start, no sphere buried in another of its body, walls for the plane-channel
 * profile, at most half a cell per step at a sphere surface, time scales
 * against the fluid step, a run whose steps can be counted, the lubrication
 * film's saturation gap below its cut-off. A failing check reports key,
 * value and allowed range (scene_report.c); an error refuses the scene, a
 * warning is only logged. */
#include "scene_internal.h"

#include <ctype.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

static const double SCENE_DX_TOLERANCE = 1e-9; /* relative, for "size is a multiple of dx" */

/* ------------------------------------------------------------------------ */
/* Numbers as written. libcyaml 1.3 reads a float with strtod and an integer
 * with strtoll without asking whether the whole scalar was used: "1,000" was
 * read as 1, "0.7 m" as 0.7, "1_000" as 1, "0o17" as 0 (PyYAML reads "1,000"
 * as a string, so the two sides disagreed). Every scalar that lands in a
 * number of the schema must therefore be a number as a whole, in the forms
 * YAML 1.1 and 1.2 agree on and strtod reads the same way: decimal with an
 * optional sign, point and exponent (1000, -0, +1.5, .5, 1e-3, 1.0E+3), a
 * hexadecimal integer (0x10 = 16 for YAML and strtod alike), and the words
 * inf, infinity and nan (any case) that strtod reads and the range checks
 * then judge. Refused: trailing text (units, digit separators, YAML 1.1's
 * 1_000 and 1:30), a whole number with a leading zero (017 is octal 15 in
 * YAML 1.1 and PyYAML, 17 in YAML 1.2 and strtod), 0o17, and strtod's hex
 * floats (0x1p3). A scalar strtod cannot read at all (".inf", "heavy") is
 * left to libcyaml, which refuses it with its own message. */

/* The length of the longest prefix of s in the forms above (0: none);
 * *leading_zero when that prefix is a whole number written with one. */
static size_t number_prefix(const char *s, bool integer, bool *leading_zero)
{
    static const char *const words[] = {"infinity", "inf", "nan"};
    size_t i = (s[0] == '+' || s[0] == '-') ? 1 : 0;
    *leading_zero = false;
    for (size_t w = 0; !integer && w < sizeof words / sizeof words[0]; w++) {
        size_t n = strlen(words[w]);
        if (strncasecmp(s + i, words[w], n) == 0) {
            return i + n;
        }
    }
    if (s[i] == '0' && (s[i + 1] == 'x' || s[i + 1] == 'X') && isxdigit((unsigned char)s[i + 2])) {
        i += 2;
        while (isxdigit((unsigned char)s[i])) {
            i++;
        }
        return i;
    }
    const size_t d0 = i;
    while (s[i] >= '0' && s[i] <= '9') {
        i++;
    }
    const size_t nint = i - d0;
    bool whole = true;
    if (!integer && s[i] == '.') {
        size_t j = i + 1;
        while (s[j] >= '0' && s[j] <= '9') {
            j++;
        }
        if (nint > 0 || j > i + 1) {
            i = j;
            whole = false;
        }
    }
    if (i == d0) {
        return 0;
    }
    if (!integer && (s[i] == 'e' || s[i] == 'E')) {
        size_t j = i + 1 + (s[i + 1] == '+' || s[i + 1] == '-');
        if (s[j] >= '0' && s[j] <= '9') {
            while (s[j] >= '0' && s[j] <= '9') {
                j++;
            }
            i = j;
            whole = false;
        }
    }
    *leading_zero = whole && nint > 1 && s[d0] == '0';
    return i;
}

/* The n characters of s for a message: control characters (a quoted "\0"
 * too) as '?', cut to `size` - 1 with "..." at the end. */
static void shown(const char *s, size_t n, char *buf, size_t size)
{
    size_t i = 0;
    for (; i < n && i + 1 < size; i++) {
        buf[i] = (unsigned char)s[i] < 0x20 || s[i] == 0x7f ? '?' : s[i];
    }
    buf[i] = '\0';
    if (i < n && size > 4) {
        memcpy(buf + size - 4, "...", 4);
    }
}

static void check_number(ctx_t *c, const char *key, const yaml_node_t *n, bool integer)
{
    const char *s = (const char *)n->data.scalar.value;
    const size_t total = n->data.scalar.length;
    bool leading_zero;
    size_t len = number_prefix(s, integer, &leading_zero);
    if (len == total && !leading_zero) {
        return;
    }
    char *end;
    (void)strtod(s, &end);
    if (len == 0 && end == s) {
        return; /* nothing libcyaml could read either: it says so */
    }
    char value[64], rest[64], head[64];
    shown(s, total, value, sizeof value);
    shown(s + len, total - len, rest, sizeof rest);
    shown(s, len, head, sizeof head);
    const char *allowed = integer ? "an integer such as 4 or -12 (no units, digit separators or leading zeros)"
                                  : "a number such as 1000, -2.5 or 1.0e-3 (no units, digit separators or leading "
                                    "zeros)";
    if (leading_zero) {
        scene_report_bad(c, key,
                         "wrong type or value ('%s' has a leading zero: octal in YAML 1.1 and PyYAML, decimal in "
                         "YAML 1.2); allowed: %s",
                         value, allowed);
    } else if (len == 0) {
        scene_report_bad(c, key, "wrong type or value ('%s' is not a number); allowed: %s", value, allowed);
    } else {
        scene_report_bad(c, key, "wrong type or value ('%s' is not a number: '%s' follows '%s'); allowed: %s", value,
                         rest, head, allowed);
    }
}

static void numbers_walk(ctx_t *c, yaml_document_t *doc, int id, const cyaml_schema_value_t *v, const char *key)
{
    const yaml_node_t *n = yaml_document_get_node(doc, id);
    if (n == NULL) {
        return;
    }
    char child[SCENE_KEY_MAX];
    if (v->type == CYAML_MAPPING && n->type == YAML_MAPPING_NODE) {
        for (const yaml_node_pair_t *p = n->data.mapping.pairs.start; p < n->data.mapping.pairs.top; p++) {
            const yaml_node_t *k = yaml_document_get_node(doc, p->key);
            if (k == NULL || k->type != YAML_SCALAR_NODE) {
                continue;
            }
            const cyaml_schema_field_t *f =
                scene_schema_field(v, (const char *)k->data.scalar.value, k->data.scalar.length);
            int len = snprintf(child, sizeof child, "%s%s%s", key, key[0] ? "." : "",
                               (const char *)k->data.scalar.value);
            if (f != NULL && len > 0 && (size_t)len < sizeof child) {
                numbers_walk(c, doc, p->value, &f->value, child);
            }
        }
    } else if (scene_schema_is_sequence(v) && n->type == YAML_SEQUENCE_NODE) {
        long i = 0;
        for (const yaml_node_item_t *it = n->data.sequence.items.start; it < n->data.sequence.items.top; it++, i++) {
            int len = snprintf(child, sizeof child, "%s%s%ld", key, key[0] ? "." : "", i);
            if (len > 0 && (size_t)len < sizeof child) {
                numbers_walk(c, doc, *it, v->sequence.entry, child);
            }
        }
    } else if (n->type == YAML_SCALAR_NODE &&
               (v->type == CYAML_FLOAT || v->type == CYAML_INT || v->type == CYAML_UINT)) {
        check_number(c, key, n, v->type != CYAML_FLOAT);
    }
    /* anything else (a list where a number belongs, ...) is libcyaml's to report */
}

void scene_check_numbers(ctx_t *c, yaml_document_t *doc)
{
    numbers_walk(c, doc, 1, &SCENE_SCHEMA, "");
}

/* ------------------------------------------------------------------------ */
/* Range checks of single values. Every failing check names key, value and
 * allowed range (LO_OPEN, HI_OPEN, ALLOW_INF: scene_internal.h).           */

bool scene_check_range(ctx_t *c, const char *key, double v, double lo, double hi, int flags)
{
    bool ok = !isnan(v) && (isfinite(v) || (flags & ALLOW_INF)) && ((flags & LO_OPEN) ? v > lo : v >= lo) &&
              ((flags & HI_OPEN) ? v < hi : v <= hi);
    if (!ok) {
        /* an infinite end is inside the range only with ALLOW_INF */
        scene_report_bad(c, key, "= %s: out of range; allowed: %s%s, %s%s", fmt_num(v).s,
                         ((flags & LO_OPEN) || (isinf(lo) && !(flags & ALLOW_INF))) ? "(" : "[",
                         fmt_num(lo).s, fmt_num(hi).s,
                         ((flags & HI_OPEN) || (isinf(hi) && !(flags & ALLOW_INF))) ? ")" : "]");
    }
    return ok;
}

bool scene_check_vec(ctx_t *c, const char *key, const double *v, int n)
{
    for (int i = 0; i < n; i++) {
        if (!isfinite(v[i])) {
            scene_report_bad(c, key, "= %s: component %d is not a finite number; allowed: finite numbers",
                             fmt_vec(v, n).s, i);
            return false;
        }
    }
    return true;
}

/* A whole number in [lo, hi] read as a double (see raw structs). */
bool scene_check_int(ctx_t *c, const char *key, double v, double lo, double hi)
{
    bool ok = isfinite(v) && v == floor(v) && v >= lo && v <= hi;
    if (!ok) {
        scene_report_bad(c, key, "= %s: not a whole number in range; allowed: an integer in [%s, %s]", fmt_num(v).s,
                         fmt_num(lo).s, fmt_num(hi).s);
    }
    return ok;
}

/* ------------------------------------------------------------------------ */
/* Consistency of the scene as a whole, in the order scene_build runs them. */

/* The lattice ties the step to the resolution, dt = (tau - 1/2) dx^2 / (3 nu).
 * dx^2 must be a positive normal double (when fluid.dt is given, tau is
 * derived through it), and a dt derived from fluid.tau one whose tenfold
 * (the default contact time) is finite as well. fluid.dx = 1e-300 m made dt
 * underflow to 0, and the scene was refused for the default
 * contacts.contact_time = 10 dt = 0, a key the file did not have, with no
 * line. Here the key of the resolution is named (fluid.dx, or
 * fluid.cells_per_radius that set it from the smallest radius rmin) with the
 * range that keeps dx^2 and dt usable for the given tau and viscosity. */
bool scene_check_step(ctx_t *c, const char *key, const scene_t *s, double rmin, bool dt_given)
{
    const scene_fluid_t *f = &s->fluid;
    const double dx2 = f->dx * f->dx, dt_max = DBL_MAX / 10;
    double lo = sqrt(DBL_MIN), hi = sqrt(DBL_MAX); /* dx for a usable dx^2 */
    char why[SCENE_MSG_MAX / 2];
    if (dt_given) {
        if (dx2 >= DBL_MIN && isfinite(dx2)) {
            return true;
        }
        snprintf(why, sizeof why, "dx^2 = %s m^2, from which tau = 1/2 + 3 nu dt / dx^2 cannot be computed",
                 fmt_num(dx2).s);
    } else {
        if (f->dt >= DBL_MIN && f->dt <= dt_max) {
            return true;
        }
        const double k = sqrt((f->tau - 0.5) / (3.0 * f->viscosity)); /* dt = (k dx)^2 */
        lo = sqrt(DBL_MIN) / k;
        hi = sqrt(dt_max) / k;
        snprintf(why, sizeof why,
                 "the step dt = (tau - 1/2) dx^2 / (3 nu) = %s s with fluid.tau = %s and fluid.viscosity = %s m^2/s, "
                 "outside the steps a run can take, [%s, %s] s",
                 fmt_num(f->dt).s, fmt_num(f->tau).s, fmt_num(f->viscosity).s, fmt_num(DBL_MIN).s, fmt_num(dt_max).s);
    }
    if (f->cells_per_radius > 0) {
        scene_report_bad(c, key, "= %s gives fluid.dx = %s m and %s; allowed: %s in [%s, %s]%s",
                         fmt_num(f->cells_per_radius).s, fmt_num(f->dx).s, why, key,
                         fmt_num(fmax(SCENE_MIN_RADIUS_CELLS, rmin / hi)).s, fmt_num(rmin / lo).s,
                         dt_given ? "" : " for this tau and viscosity");
    } else {
        scene_report_bad(c, key, "= %s m gives %s; allowed: %s in [%s, %s] m%s", fmt_num(f->dx).s, why, key,
                         fmt_num(lo).s, fmt_num(hi).s, dt_given ? "" : " for this tau and viscosity");
    }
    return false;
}

void scene_check_divisible(ctx_t *c, const scene_t *s)
{
    double dx = s->fluid.dx;
    for (int a = 0; a < 3; a++) {
        double n = s->domain.size[a] / dx;
        double nr = round(n);
        if (nr < 1 || fabs(n - nr) > SCENE_DX_TOLERANCE * n) {
            scene_report_bad(c, "domain.size",
                             "= %s: the %c extent %s m is %s cells of fluid.dx = %s m; allowed: a whole number "
                             "(>= 1) of cells (relative tolerance %s)",
                             fmt_vec(s->domain.size, 3).s, AXIS_NAMES[a], fmt_num(s->domain.size[a]).s, fmt_num(n).s,
                             fmt_num(dx).s, fmt_num(SCENE_DX_TOLERANCE).s);
        }
    }
}

static bool axis_periodic(const scene_t *s, int a)
{
    return s->domain.faces[2 * a].type == FACE_PERIODIC;
}

/* d = b - a at the nearest image along the periodic axes (with periodic;
 * else as given), and its length. */
static double image_diff(const scene_t *s, const double a[3], const double b[3], bool periodic, double d[3])
{
    double d2 = 0.0;
    for (int k = 0; k < 3; k++) {
        d[k] = b[k] - a[k];
        if (periodic && axis_periodic(s, k)) {
            d[k] -= s->domain.size[k] * round(d[k] / s->domain.size[k]);
        }
        d2 += d[k] * d[k];
    }
    return sqrt(d2);
}

void scene_check_spheres(ctx_t *c, const scene_t *s, bool domain_ok, bool dx_ok)
{
    char key[SCENE_KEY_MAX];
    int g = 0;
    bool thin[3] = {false, false, false}; /* a thin periodic slab warned of, per axis */
    const bool several = scene_total_spheres(s) > 1; /* another sphere's image can be missed */
    for (int i = 0; i < s->nbodies; i++) {
        const scene_body_t *b = &s->bodies[i];
        for (int k = 0; k < b->nspheres; k++, g++) {
            const scene_sphere_t *sp = &b->spheres[k];
            if (!(sp->radius > 0) || !isfinite(sp->radius)) {
                continue; /* already reported */
            }
            snprintf(key, sizeof key, "bodies.%d.spheres.%d.radius", i, k);
            if (dx_ok && sp->radius < SCENE_MIN_RADIUS_CELLS * s->fluid.dx * (1 - 1e-12)) {
                scene_report_bad(c, key,
                                 "= %s m is %s cells of fluid.dx = %s m (sphere %d); allowed: at least %s cells = %s m",
                                 fmt_num(sp->radius).s, fmt_num(sp->radius / s->fluid.dx).s, fmt_num(s->fluid.dx).s, g,
                                 fmt_num(SCENE_MIN_RADIUS_CELLS).s, fmt_num(SCENE_MIN_RADIUS_CELLS * s->fluid.dx).s);
            }
            if (!domain_ok) {
                continue;
            }
            snprintf(key, sizeof key, "bodies.%d.spheres.%d.center", i, k);
            for (int a = 0; a < 3; a++) {
                double x = sp->center[a], r = sp->radius, L = s->domain.size[a];
                if (!isfinite(x)) {
                    break;
                }
                if (axis_periodic(s, a)) {
                    if (!(x >= 0 && x < L)) {
                        scene_report_bad(c, key,
                                         "= %s (sphere %d): the %c coordinate %s is outside the periodic "
                                         "domain; allowed: %c in [0, %s)",
                                         fmt_vec(sp->center, 3).s, g, AXIS_NAMES[a], fmt_num(x).s, AXIS_NAMES[a],
                                         fmt_num(L).s);
                    } else if (2 * r > L) {
                        scene_report_bad(c, key,
                                         "= %s (sphere %d): diameter %s m exceeds the periodic length %s m "
                                         "along %c, so the sphere overlaps its own image; allowed: radius <= %s m",
                                         fmt_vec(sp->center, 3).s, g, fmt_num(2 * r).s, fmt_num(L).s,
                                         AXIS_NAMES[a], fmt_num(L / 2).s);
                    } else if (dx_ok && several && !thin[a] && L < 2 * (r + sqrt(2.0) * s->fluid.dx)) {
                        thin[a] = true; /* once per axis, for the first sphere too large for it */
                        scene_report_warn(c, key,
                                          "= %s (sphere %d): the periodic length %s m along %c is shorter than 2 (r + "
                                          "sqrt(2) dx) = %s m, a thin periodic slab, where another sphere's far image "
                                          "could be missed (README \"Known problems\"); a length of at least that "
                                          "is safe",
                                          fmt_vec(sp->center, 3).s, g, fmt_num(L).s, AXIS_NAMES[a],
                                          fmt_num(2 * (r + sqrt(2.0) * s->fluid.dx)).s);
                    }
                } else if (2 * r > L) {
                    /* no centre fits: the range below would be empty ([r, L - r] with L - r < r) */
                    scene_report_bad(c, key,
                                     "= %s (sphere %d): diameter %s m exceeds the distance %s m between the walls "
                                     "along %c; allowed: radius <= %s m",
                                     fmt_vec(sp->center, 3).s, g, fmt_num(2 * r).s, fmt_num(L).s, AXIS_NAMES[a],
                                     fmt_num(L / 2).s);
                } else if (!(x - r >= 0 && x + r <= L)) {
                    scene_report_bad(c, key,
                                     "= %s with radius %s (sphere %d) reaches outside the walls along %c: "
                                     "[%s, %s]; allowed: %c in [%s, %s]",
                                     fmt_vec(sp->center, 3).s, fmt_num(r).s, g, AXIS_NAMES[a], fmt_num(x - r).s,
                                     fmt_num(x + r).s, AXIS_NAMES[a], fmt_num(r).s, fmt_num(L - r).s);
                }
            }
        }
    }
}

/* Spheres of different bodies must not overlap at start; on periodic axes
 * the nearest image counts. O(n^2), fine for the few thousand spheres of a
 * scene. Spheres of one body may overlap (sintered). */
void scene_check_overlaps(ctx_t *c, const scene_t *s, bool domain_ok)
{
    char key[SCENE_KEY_MAX];
    int gi = 0;
    for (int i = 0; i < s->nbodies; i++) {
        for (int k = 0; k < s->bodies[i].nspheres; k++, gi++) {
            const scene_sphere_t *p = &s->bodies[i].spheres[k];
            int gj = gi - k + s->bodies[i].nspheres;
            for (int j = i + 1; j < s->nbodies; j++) {
                for (int l = 0; l < s->bodies[j].nspheres; l++, gj++) {
                    const scene_sphere_t *q = &s->bodies[j].spheres[l];
                    double dv[3];
                    const double dist = image_diff(s, q->center, p->center, domain_ok, dv);
                    const double rsum = p->radius + q->radius;
                    if (dist < rsum && !scene_report_shown(c)) {
                        scene_report_count(c, STATUS_ERROR);
                    } else if (dist < rsum) {
                        snprintf(key, sizeof key, "bodies.%d.spheres.%d.center", j, l);
                        scene_report_bad(c, key,
                                         "= %s (sphere %d, body %d) overlaps sphere %d of body %d at %s: "
                                         "centre distance %s m < sum of radii %s m; allowed: distance >= sum "
                                         "of radii for spheres of different bodies",
                                         fmt_vec(q->center, 3).s, gj, j, gi, i, fmt_vec(p->center, 3).s,
                                         fmt_num(dist).s, fmt_num(rsum).s);
                    }
                }
            }
        }
    }
}

/* A sphere of a body buried in another sphere of the same body. The rigid
 * component splits a body's volume between its spheres at the radical plane
 * of each overlapping pair, the plane of the circle where their surfaces meet
 * (rigid/body.c), and needs that plane to pass between the two centres:
 * t = (d^2 + r^2 - R^2) / (2 d) > 0 for the smaller sphere (radius r; R the
 * other, d the centre distance), as it computes it. A sphere entirely inside
 * another (d + r <= R), or deep enough that its centre lies beyond that
 * plane, or one that coincides with another (d = 0) passed `coupler check`
 * and was then refused by the rigid component at start-up ("distance inf m",
 * "-nan m" for two equal coincident spheres). The smaller sphere is named
 * (the later of two equal ones); on periodic axes the nearest image counts. */
static void check_buried_pair(ctx_t *c, const scene_t *s, int i, int k, int j, int gk, int gj, bool domain_ok)
{
    const scene_sphere_t *p = &s->bodies[i].spheres[k], *q = &s->bodies[i].spheres[j];
    double dv[3];
    const double d = image_diff(s, q->center, p->center, domain_ok, dv), r = p->radius, R = q->radius;
    if (!isfinite(d) || !(r > 0) || !(R > 0) || !isfinite(r + R)) {
        return; /* already reported */
    }
    if (d >= r + R || (d > 0 && d * d + r * r - R * R > 0)) {
        return; /* apart, touching, or sintered with the plane between the centres */
    }
    if (!scene_report_shown(c)) {
        scene_report_count(c, STATUS_ERROR); /* formatting n^2 hidden messages took minutes */
        return;
    }
    char key[SCENE_KEY_MAX], how[SCENE_MSG_MAX / 4];
    if (d == 0) {
        snprintf(how, sizeof how, "the two centres coincide, so it adds nothing to the body: remove it");
    } else if (d + r <= R) {
        snprintf(how, sizeof how,
                 "it lies entirely inside (centre distance %s m + radius %s m <= %s m), so it adds nothing to the "
                 "body: remove it",
                 fmt_num(d).s, fmt_num(r).s, fmt_num(R).s);
    } else {
        snprintf(how, sizeof how, "its centre lies beyond the plane where the two surfaces meet (centre distance %s m)",
                 fmt_num(d).s);
    }
    snprintf(key, sizeof key, "bodies.%d.spheres.%d.center", i, k);
    scene_report_bad(c, key,
                     "= %s (sphere %d, radius %s m, body %d) is buried in sphere %d of the same body at %s (radius %s "
                     "m): %s; allowed: centre distance > sqrt(R^2 - r^2) = %s m, the plane where the surfaces meet "
                     "between the centres (the rigid component splits the body's volume between its spheres there)",
                     fmt_vec(p->center, 3).s, gk, fmt_num(r).s, i, gj, fmt_vec(q->center, 3).s, fmt_num(R).s, how,
                     fmt_num(sqrt(R * R - r * r)).s);
}

void scene_check_buried(ctx_t *c, const scene_t *s, bool domain_ok)
{
    int g0 = 0; /* global index of the body's first sphere */
    for (int i = 0; i < s->nbodies; g0 += s->bodies[i].nspheres, i++) {
        const scene_body_t *b = &s->bodies[i];
        for (int k = 1; k < b->nspheres; k++) {
            for (int j = 0; j < k; j++) {
                if (b->spheres[k].radius <= b->spheres[j].radius) {
                    check_buried_pair(c, s, i, k, j, g0 + k, g0 + j, domain_ok);
                } else {
                    check_buried_pair(c, s, i, j, k, g0 + j, g0 + k, domain_ok);
                }
            }
        }
    }
}

/* A body across a periodic face: its spheres' centres, each given in [0, L),
 * moved to the images that make the body one piece (each to the image
 * nearest a sphere it touches, from the body's first sphere on), so that its
 * centroid, its turning and its mass properties are those of the body and
 * not of its pieces scattered over the box. A sphere that touches none of
 * the others goes to the image nearest the first sphere (the rigid component
 * then reports the body as not one piece). The components wrap the centres
 * into the box where they place spheres in it. */
void scene_unwrap_bodies(scene_t *s)
{
    for (int i = 0; i < s->nbodies; i++) {
        scene_body_t *b = &s->bodies[i];
        int *stack = malloc((size_t)b->nspheres * sizeof *stack);
        unsigned char *seen = calloc((size_t)b->nspheres, 1);
        int top = 0;
        if (stack != NULL && seen != NULL && b->nspheres > 0) {
            stack[top++] = 0;
            seen[0] = 1;
        }
        while (top > 0) {
            const scene_sphere_t *u = &b->spheres[stack[--top]];
            for (int k = 0; k < b->nspheres; k++) {
                scene_sphere_t *v = &b->spheres[k];
                double d[3];
                const double touch = (u->radius + v->radius) * (1.0 + SCENE_TOUCH_TOL);
                if (seen[k] || image_diff(s, u->center, v->center, true, d) > touch) {
                    continue;
                }
                for (int a = 0; a < 3; a++) {
                    v->center[a] = u->center[a] + d[a];
                }
                seen[k] = 1;
                stack[top++] = k;
            }
        }
        for (int k = 1; k < b->nspheres; k++) {
            if (seen == NULL || !seen[k]) {
                double d[3];
                image_diff(s, b->spheres[0].center, b->spheres[k].center, true, d);
                for (int a = 0; a < 3; a++) {
                    b->spheres[k].center[a] = b->spheres[0].center[a] + d[a];
                }
            }
        }
        free(stack);
        free(seen);
    }
}

/* A free body's mass and moments of inertia must be numbers the rigid
 * component can divide by: normal (>= DBL_MIN) and finite. Each key was in
 * its range, but `density: 1e-308` made the mass of a sphere of 0.3 mm
 * subnormal and its moment of inertia 0, and `density: 1e308` made a 2 m
 * sphere's mass inf; both passed `coupler check`, and the run stopped at its
 * first step with the rigid component's NaN blamed on the fluid's input
 * ("fmi2SetReal: sphere[0].position.x (value reference 6) = -nan"). Bounds
 * from the spheres' volumes (overlaps ignored): the smallest moment is at
 * least that of the smallest sphere alone about its centre, 2/5 m r^2 with
 * its own mass, the largest at most the whole mass at the body's extent. */
void scene_check_masses(ctx_t *c, const scene_t *s)
{
    char key[SCENE_KEY_MAX];
    for (int i = 0; i < s->nbodies; i++) {
        const scene_body_t *b = &s->bodies[i];
        if (b->motion != MOTION_FREE || b->nspheres == 0) {
            continue;
        }
        double vol = 0.0, vmin = INFINITY, lo[3], hi[3];
        for (int a = 0; a < 3; a++) {
            lo[a] = INFINITY;
            hi[a] = -INFINITY;
        }
        for (int k = 0; k < b->nspheres; k++) {
            const scene_sphere_t *p = &b->spheres[k];
            const double v = 4.0 / 3.0 * 3.14159265358979323846 * p->radius * p->radius * p->radius;
            vol += v;
            vmin = fmin(vmin, 0.4 * v * p->radius * p->radius); /* its moment per density */
            for (int a = 0; a < 3; a++) {
                lo[a] = fmin(lo[a], p->center[a] - p->radius);
                hi[a] = fmax(hi[a], p->center[a] + p->radius);
            }
        }
        const double ext2 = (hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                            (hi[2] - lo[2]) * (hi[2] - lo[2]);
        const double rho = b->density, mass = rho * vol, imin = rho * vmin, imax = mass * ext2;
        if (mass >= DBL_MIN && imin >= DBL_MIN && isfinite(mass) && isfinite(imax)) {
            continue;
        }
        /* the densities that give usable numbers */
        const double dlo = fmax(DBL_MIN / vol, DBL_MIN / vmin),
                     dhi = fmin(DBL_MAX, fmin(DBL_MAX / vol, DBL_MAX / (vol * ext2)));
        snprintf(key, sizeof key, "bodies.%d.density", i);
        scene_report_bad(c, key,
                         "= %s kg/m^3 gives the body a mass of %s kg (volume %s m^3) and moments of inertia between "
                         "%s and %s kg m^2, %s the rigid component can divide by; allowed: a mass and moments of "
                         "inertia in [%s, %s], here a density in [%s, %s] kg/m^3",
                         fmt_num(rho).s, fmt_num(mass).s, fmt_num(vol).s, fmt_num(imin).s, fmt_num(imax).s,
                         mass >= DBL_MIN && imin >= DBL_MIN ? "beyond the numbers" : "below the smallest numbers",
                         fmt_num(DBL_MIN).s, fmt_num(DBL_MAX).s, fmt_num(dlo).s, fmt_num(dhi).s);
    }
}

/* A sphere surface point must not move more than half a cell per LBM step
 * (the link lists and refill assume it; the fluid refuses a larger move of a
 * sphere, fluid_set_sphere). The body's reference point is the
 * volume-weighted centroid of its spheres (overlaps ignored): an estimate,
 * good enough for a start-up check. An error for prescribed motion (it keeps
 * that speed) and for the initial velocity of a free body (its first step
 * would be refused). */
void scene_check_speeds(ctx_t *c, const scene_t *s)
{
    char key[SCENE_KEY_MAX];
    double limit = 0.5 * s->fluid.dx / s->fluid.dt;
    for (int i = 0; i < s->nbodies; i++) {
        const scene_body_t *b = &s->bodies[i];
        if (b->motion == MOTION_FIXED) {
            continue;
        }
        double cen[3] = {0, 0, 0}, vol = 0;
        for (int k = 0; k < b->nspheres; k++) {
            double w = pow(b->spheres[k].radius, 3);
            vol += w;
            for (int a = 0; a < 3; a++) {
                cen[a] += w * b->spheres[k].center[a];
            }
        }
        const double centroid[3] = {cen[0] / vol, cen[1] / vol, cen[2] / vol};
        double reach = 0, d[3];
        for (int k = 0; k < b->nspheres; k++) {
            /* the body is one piece (scene_unwrap_bodies): no images */
            reach = fmax(reach, image_diff(s, centroid, b->spheres[k].center, false, d) + b->spheres[k].radius);
        }
        const double *v = b->velocity, *w = b->angular_velocity;
        double speed = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) * reach;
        if (!(speed <= limit)) {
            snprintf(key, sizeof key, "bodies.%d.velocity", i);
            scene_report_bad(c, key,
                             "= %s with angular velocity %s moves a surface point up to %s m/s = %s cells per "
                             "step; allowed: at most 0.5 cells per step = %s m/s (fluid.dx / (2 fluid.dt)): a "
                             "smaller fluid.dt (fluid.tau closer to 0.5), a smaller fluid.dx or a lower velocity",
                             fmt_vec(v, 3).s, fmt_vec(w, 3).s, fmt_num(speed).s,
                             fmt_num(speed * s->fluid.dt / s->fluid.dx).s, fmt_num(limit).s);
        }
    }
}

/* fluid.initial_profile = plane_channel needs exactly one axis with walls
 * (no_slip or moving_wall on both faces); the others periodic or free-slip. */
void scene_check_initial_profile(ctx_t *c, scene_t *s)
{
    scene_fluid_t *f = &s->fluid;
    if (f->initial_profile != INITIAL_PLANE_CHANNEL) {
        return;
    }
    int axis = -1, nwalled = 0;
    for (int a = 0; a < 3; a++) {
        face_type_t t0 = s->domain.faces[2 * a].type, t1 = s->domain.faces[2 * a + 1].type;
        bool wall0 = t0 == FACE_NO_SLIP || t0 == FACE_MOVING_WALL, wall1 = t1 == FACE_NO_SLIP || t1 == FACE_MOVING_WALL;
        bool open0 = t0 == FACE_PERIODIC || t0 == FACE_FREE_SLIP, open1 = t1 == FACE_PERIODIC || t1 == FACE_FREE_SLIP;
        if (wall0 && wall1) {
            axis = a;
            nwalled++;
        } else if (!(open0 && open1)) {
            nwalled = 99; /* an inlet, an outlet or one wall only */
        }
    }
    if (nwalled != 1) {
        scene_report_bad(c, "fluid.initial_profile",
                         "= plane_channel needs exactly one axis bounded by two walls (no_slip or moving_wall) "
                         "and the other faces periodic or free_slip; allowed otherwise: uniform");
        return;
    }
    f->channel_axis = axis;
}

void scene_check_time_scales(ctx_t *c, const scene_t *s)
{
    /* dt derived from tau carries round-off: one step is "at least dt within 1e-9" */
    double dt = s->fluid.dt * (1.0 - 1e-9);
    if (s->run.output_interval > 0 && s->run.output_interval < dt) {
        scene_report_warn(c, "run.output_interval",
                          "= %s s is shorter than one fluid step fluid.dt = %s s; output every step",
                          fmt_num(s->run.output_interval).s, fmt_num(s->fluid.dt).s);
    }
    if (s->run.end_time > 0 && s->run.end_time < dt) {
        scene_report_warn(c, "run.end_time", "= %s s is shorter than one fluid step fluid.dt = %s s",
                          fmt_num(s->run.end_time).s, fmt_num(s->fluid.dt).s);
    }
    double rigid_dt = s->fluid.dt / s->rigid.substeps;
    if (s->contacts.model == CONTACT_SPRING_DASHPOT && s->contacts.contact_time > 0 &&
        s->contacts.contact_time < 10 * rigid_dt) {
        scene_report_warn(c, "contacts.contact_time",
                          "= %s s spans only %s rigid steps of fluid.dt / rigid.substeps = %s s; at least 10 "
                          "are advised (raise rigid.substeps)",
                          fmt_num(s->contacts.contact_time).s, fmt_num(s->contacts.contact_time / rigid_dt).s,
                          fmt_num(rigid_dt).s);
    }
    if (s->rigid.release_time > 0) {
        double rmax = 0.0;
        for (int b = 0; b < s->nbodies; b++) {
            for (int k = 0; k < s->bodies[b].nspheres && s->bodies[b].motion == MOTION_FREE; k++) {
                rmax = fmax(rmax, s->bodies[b].spheres[k].radius);
            }
        }
        const double tv = s->fluid.viscosity > 0 ? rmax * rmax / s->fluid.viscosity : 0.0;
        if (rmax == 0.0) {
            scene_report_warn(c, "rigid.release_time", "= %s s, but no body is free: nothing is held",
                              fmt_num(s->rigid.release_time).s);
        } else if (s->rigid.release_time >= s->run.end_time) {
            scene_report_warn(c, "rigid.release_time",
                              "= %s s is not before run.end_time = %s s: the free bodies are held for the whole run",
                              fmt_num(s->rigid.release_time).s, fmt_num(s->run.end_time).s);
        } else if (s->rigid.release_time < 0.1 * tv) {
            scene_report_warn(c, "rigid.release_time",
                              "= %s s is short of the time the flow around a sphere takes to form, r^2/nu = %s s "
                              "(largest free sphere): part of the start-up load remains (README \"Release\")",
                              fmt_num(s->rigid.release_time).s, fmt_num(tv).s);
        }
    }
}

/* The run is counted in fluid steps, ceil(run.end_time / fluid.dt) as
 * coupler/run.c, fluid/units.c and the fluid FMU compute it, a `long`
 * multiplied back by dt in double: the count must stay within
 * SCENE_STEPS_MAX = 2^53, where both are exact (far below LONG_MAX).
 * run.end_time = 1e15 s at dt = 1.7e-5 s made 6e19 steps and `coupler check`
 * printed "steps -9223372036854775808". */
_Static_assert(LONG_MAX >= SCENE_STEPS_MAX, "step counts are longs");

void scene_check_run_length(ctx_t *c, const scene_t *s)
{
    const scene_run_t *u = &s->run;
    const double dt = s->fluid.dt;
    if (!(u->end_time > 0) || !isfinite(u->end_time)) {
        return; /* already reported */
    }
    const double steps = ceil(u->end_time / dt - 1e-9);
    if (!(steps <= (double)SCENE_STEPS_MAX)) {
        scene_report_bad(c, "run.end_time",
                         "= %s s is %s steps of fluid.dt = %s s, more than a run can count; allowed: at most %lld "
                         "(2^53) steps, i.e. run.end_time <= %s s",
                         fmt_num(u->end_time).s, fmt_num(steps).s, fmt_num(dt).s, SCENE_STEPS_MAX,
                         fmt_num((double)SCENE_STEPS_MAX * dt).s);
    }
}

/* The lubrication film force saturates at min_gap before it vanishes at the
 * cut-off: min_gap (m) must lie below cutoff (cells) x fluid.dx. */
void scene_check_lubrication(ctx_t *c, const scene_t *s)
{
    const scene_lubrication_t *l = &s->contacts.lubrication;
    double hc = l->cutoff * s->fluid.dx;
    if (!l->enabled || scene_total_spheres(s) == 0 || l->min_gap < hc) {
        return;
    }
    scene_report_bad(c, "contacts.lubrication.min_gap",
                     "= %s m is not below the cut-off contacts.lubrication.cutoff x fluid.dx = %s x %s m = %s m; "
                     "allowed: (0, %s) m (default: 1e-3 of the smallest sphere radius)",
                     fmt_num(l->min_gap).s, fmt_num(l->cutoff).s, fmt_num(s->fluid.dx).s, fmt_num(hc).s,
                     fmt_num(hc).s);
}

/* The volume two spheres share (the lens; the smaller sphere when one
 * holds the other). A body's volume is its spheres' less their lenses, as
 * the rigid component's union (rigid/body.c) where no three overlap. */
static double lens_volume(const scene_sphere_t *a, const scene_sphere_t *b)
{
    const double pi = 3.14159265358979323846, r1 = a->radius, r2 = b->radius;
    const double d = sqrt(pow(a->center[0] - b->center[0], 2) + pow(a->center[1] - b->center[1], 2) +
                          pow(a->center[2] - b->center[2], 2));
    if (d >= r1 + r2) {
        return 0.0;
    }
    if (d <= fabs(r1 - r2)) {
        return 4.0 / 3.0 * pi * pow(fmin(r1, r2), 3.0);
    }
    return pi * (r1 + r2 - d) * (r1 + r2 - d) * (d * d + 2.0 * d * (r1 + r2) - 3.0 * (r1 - r2) * (r1 - r2)) /
           (12.0 * d);
}

/* A box that no face or held body can push against along a periodic axis
 * (every face periodic, or free-slip, which takes the normal component
 * only; no fixed or prescribed body) cannot take a net external force along
 * it: the free bodies' net weight, (rho_b - rho_f) V_b g (the rigid
 * component adds the buoyancy), and the fluid's body force on its volume
 * then accelerate the whole suspension without bound, and a "settling" body
 * never reaches a terminal velocity (a sphere of density ratio 2, radius 4
 * cells, in a periodic 24^3 box with gravity: 0.0035 m/s after 3000 steps
 * and still rising by 0.00057 m/s per 600, against 0.00049 m/s with the
 * balancing body force). A periodic suspension's weight is carried by the
 * mean pressure gradient: the fluid's body force minus the net weight over
 * the fluid's volume. A warning with that body force; a body's volume is
 * the union of its spheres (lens_volume), and the tolerance of 1e-2 covers
 * the rest (three spheres overlapping, the rounding of a hand-computed
 * body force). */
void scene_check_net_force(ctx_t *c, const scene_t *s)
{
    double vbox = s->domain.size[0] * s->domain.size[1] * s->domain.size[2], vsph = 0.0, w[3] = {0, 0, 0}, wabs = 0.0;
    int nfree = 0;
    for (int f = 0; f < 6; f++) {
        const face_type_t t = s->domain.faces[f].type;
        if (t != FACE_PERIODIC && t != FACE_FREE_SLIP) {
            return; /* a wall, an inlet or an outlet takes any force */
        }
    }
    for (int b = 0; b < s->nbodies; b++) {
        const scene_body_t *body = &s->bodies[b];
        double vb = 0.0;
        for (int k = 0; k < body->nspheres; k++) {
            vb += 4.0 / 3.0 * 3.14159265358979323846 * pow(body->spheres[k].radius, 3.0);
            for (int j = 0; j < k; j++) {
                vb -= lens_volume(&body->spheres[k], &body->spheres[j]);
            }
        }
        vsph += vb;
        if (body->motion != MOTION_FREE) {
            return; /* a held body takes any force */
        }
        nfree++;
        for (int a = 0; a < 3; a++) {
            const double wa = (body->density - s->fluid.density) * vb * s->rigid.gravity[a];
            w[a] += wa;
            wabs += fabs(wa);
        }
    }
    const double vfluid = vbox - vsph;
    if (nfree == 0 || !(vfluid > 0.0)) {
        return; /* without bodies: fluid/units.c warns of a body force in a box without walls */
    }
    double net[3], fix[3], scale = wabs, unbalanced = 0.0;
    int axis = -1;
    for (int a = 0; a < 3; a++) {
        scale += fabs(s->fluid.body_force[a]) * vfluid;
        const int free_axis = s->domain.faces[2 * a].type == FACE_PERIODIC;
        net[a] = free_axis ? w[a] + s->fluid.body_force[a] * vfluid : 0.0;
        fix[a] = s->fluid.body_force[a] - net[a] / vfluid;
        if (fabs(net[a]) > unbalanced) {
            unbalanced = fabs(net[a]);
            axis = a;
        }
    }
    if (!(unbalanced > 1e-2 * scale) || axis < 0) {
        return;
    }
    const int by_gravity = fabs(w[axis]) >= fabs(s->fluid.body_force[axis]) * vfluid;
    scene_report_warn(c, by_gravity ? "rigid.gravity" : "fluid.body_force",
                      "= %s: the free bodies' net weight (%s N, buoyancy included) and the fluid's body force on "
                      "its volume (%s N) leave %s N along the periodic %c axis, where no face or held body can take "
                      "it: the whole suspension accelerates without bound and no terminal velocity is reached. A "
                      "periodic suspension's weight is carried by the mean pressure gradient: set fluid.body_force "
                      "= %s N/m^3 (the net weight over the fluid's volume, the other way), or close the box with "
                      "walls",
                      fmt_vec(by_gravity ? s->rigid.gravity : s->fluid.body_force, 3).s, fmt_vec(w, 3).s,
                      fmt_num(s->fluid.body_force[axis] * vfluid).s, fmt_vec(net, 3).s, AXIS_NAMES[axis],
                      fmt_vec(fix, 3).s);
}
