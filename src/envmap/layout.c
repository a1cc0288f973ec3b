/* Input layouts (angular probe, mirror ball, cube crosses, strips, OpenEXR envmap) to and from
 * the canonical lat-long frame.
 *
 * ---- Orientation choices (the project's documented conventions) ---------------------------
 *
 * Canonical frame (docs/design.md): right-handed, +Z up; lat-long column c, row r of W x H:
 * u = (c + 0.5)/W, v = (r + 0.5)/H, phi = pi (1 - 2u), theta = pi (0.5 - v),
 * d = (cos theta cos phi, cos theta sin phi, sin theta). u = 0.5 -> +X, u = 0.25 -> +Y.
 *
 * Probes (angular map and mirror ball). Image-local frame: x = right, y = up, z = towards the
 * viewer, so "forward" (into the image) is -z. Canonical = (-z_img, -x_img, y_img): forward ->
 * +X (the centre of the lat-long), image up -> +Z, image right -> -Y (looking along +X with +Z
 * up, -Y is on the right). The disc is the one inscribed in the image: centre (W/2, H/2), radius
 * min(W, H)/2 in pixel units (pixel i covers [i, i+1)); normalized (x, y) = ((px - cx)/R,
 * (cy - py)/R).
 *  - Angular (Debevec): radius linear in angle, centre = forward, rim = backward. A point at
 *    normalized radius r and image angle a = atan2(y, x) looks along
 *    d_img = (sin(pi r) cos a, sin(pi r) sin a, -cos(pi r)).
 *  - Mirror ball: an orthographic photograph of a mirrored sphere; the view direction is
 *    (0, 0, -1). Ball normal at (x, y): n = (x, y, sqrt(1 - x^2 - y^2)); the direction seen
 *    there is the reflection d_img = v - 2 (v.n) n = (2 nz x, 2 nz y, 2 nz^2 - 1): the centre
 *    sees backward (+z_img, towards the camera, canonical -X), the rim sees forward (+X).
 *    Inverse: n = normalize(d_img + (0, 0, 1)). The mapping is equal-area: dw/dA = 4 (unit
 *    radius).
 *  Both cover the whole sphere (the angular rim is the single direction -X, the mirror ball's
 *  rim is +X), so no direction is uncovered. Pixels outside the disc are ignored on input and
 *  written as 0 on output.
 *
 * Cube faces of the crosses and strips, as seen from inside the cube. A face has a centre
 * direction c, a right vector rt and an up vector up (canonical); face coordinates s, t in
 * [-1, 1] (s to the right, t up, pixel centres at s = 2 (i + 0.5)/N - 1, t = 1 - 2 (j + 0.5)/N)
 * look along normalize(c + s rt + t up):
 *    front  +X: c = ( 1, 0, 0)  rt = ( 0,-1, 0)  up = ( 0, 0, 1)
 *    left   +Y: c = ( 0, 1, 0)  rt = ( 1, 0, 0)  up = ( 0, 0, 1)
 *    right  -Y: c = ( 0,-1, 0)  rt = (-1, 0, 0)  up = ( 0, 0, 1)
 *    back   -X: c = (-1, 0, 0)  rt = ( 0, 1, 0)  up = ( 0, 0, 1)
 *    top    +Z: c = ( 0, 0, 1)  rt = ( 0,-1, 0)  up = (-1, 0, 0)
 *    bottom -Z: c = ( 0, 0,-1)  rt = ( 0,-1, 0)  up = ( 1, 0, 0)
 *  Horizontal cross (4 x 3 faces): row 0: top above front; row 1: left, front, right, back;
 *  row 2: bottom below front. Vertical cross (3 x 4 faces): row 0: top (middle column); row 1:
 *  left, front, right; row 2: bottom; row 3: back, drawn turned by 180 degrees so that its edge
 *  with the bottom face is continuous: c = (-1, 0, 0), rt = (0, -1, 0), up = (0, 0, -1).
 *  Strips (6 x 1 side by side, 1 x 6 stacked): front, back, left, right, top, bottom, each as
 *  in the table. Every edge shared by neighbouring faces of a cross is continuous (tested).
 *
 * OpenEXR envmap files (ImfEnvmap.h/.cpp conventions) use a Y-up frame. We map it to the
 * canonical frame by the cyclic permutation canonical = (z_exr, x_exr, y_exr), a rotation
 * (det +1). It makes OpenEXR's lat-long coincide with ours: OpenEXR longitude 0 (+Z_exr) is the
 * image centre and becomes +X (u = 0.5); +X_exr (longitude +pi/2, a quarter from the left)
 * becomes +Y (u = 0.25); +Y_exr (up) becomes +Z.
 *  - Lat-long (pixel centres on integer positions px, py, data window from (0,0)):
 *    latitude = -pi (py/(H-1) - 0.5), longitude = -2 pi (px/(W-1) - 0.5) (0 when H or W is 1);
 *    no half-pixel offset: row 0 is exactly +pi/2, column 0 and column W-1 are both longitude
 *    pi / -pi (the same meridian). d_exr = (sin lon cos lat, sin lat, cos lon cos lat), hence
 *    canonical d = (cos lon cos lat, sin lon cos lat, sin lat).
 *  - Cube: N x 6N (N = min(W, H/6)), faces +X, -X, +Y, -Y, +Z, -Z (OpenEXR's axes) stacked top
 *    to bottom. Within a face, OpenEXR's "position in face" (pif, 0..N-1) gives
 *    pos = pif/(N-1) * 2 - 1 (0 if N = 1) and the direction +X: (1, pos.x, pos.y), -X: (-1,
 *    pos.x, pos.y), +Y: (pos.x, 1, pos.y), -Y: (pos.x, -1, pos.y), +Z: (pos.x, pos.y, 1), -Z:
 *    (pos.x, pos.y, -1); the pixel of pif in the face (px, py relative to the face's corner) is
 *    +X: (pif.y, N-1-pif.x), -X: (N-1-pif.y, N-1-pif.x), +Y: (pif.x, N-1-pif.y), -Y: (pif.x,
 *    pif.y), +Z: (N-1-pif.x, N-1-pif.y), -Z: (pif.x, N-1-pif.y). Every face is then seen from
 *    inside the cube.
 *
 * ---- Sampling ---------------------------------------------------------------------------------
 *
 * Both directions are area-weighted: an output pixel is the solid-angle weighted mean of the
 * input over the output pixel's footprint, estimated with nx x ny stratified sub-samples and a
 * bilinear reconstruction of the input (clamped within a face; taps whose centres lie outside a
 * probe's disc are dropped and the rest renormalized). The sub-sample counts follow the ratio of
 * the output pixel's angular size to the input pixel's (smallest local) angular size, at least 2
 * and at most ENVL_LAYOUT_MAX_SUB per axis. Lat-long outputs are stratified in azimuth and in
 * z = sin(elevation), so every sub-sample stands for the same solid angle; other outputs weight
 * each sub-sample by the layout's dw/dA.
 */
#include "internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define ENVL_LAYOUT_MAX_SUB 16

/* ---- cube faces ---- */
enum { F_FRONT, F_BACK, F_LEFT, F_RIGHT, F_TOP, F_BOTTOM, F_BACK_V,
       F_GL_PX, F_GL_NX, F_GL_PY, F_GL_NY, F_GL_PZ, F_GL_NZ, F_COUNT };

/* centre, right, up */
static const double face_frame[F_COUNT][3][3] = {
    [F_FRONT] = {{1, 0, 0}, {0, -1, 0}, {0, 0, 1}},
    [F_BACK] = {{-1, 0, 0}, {0, 1, 0}, {0, 0, 1}},
    [F_LEFT] = {{0, 1, 0}, {1, 0, 0}, {0, 0, 1}},
    [F_RIGHT] = {{0, -1, 0}, {-1, 0, 0}, {0, 0, 1}},
    [F_TOP] = {{0, 0, 1}, {0, -1, 0}, {-1, 0, 0}},
    [F_BOTTOM] = {{0, 0, -1}, {0, -1, 0}, {1, 0, 0}},
    [F_BACK_V] = {{-1, 0, 0}, {0, -1, 0}, {0, 0, -1}},
    /* OpenGL's cube faces in the glTF frame (x, z, -y of ours): its table (sc, tc, ma) gives
     * face +X: s = -z / x, t = -y / x, t growing down the rows; in our axes: */
    [F_GL_PX] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}},     /* +X_gl: right -Z_gl = +Y, up +Y_gl */
    [F_GL_NX] = {{-1, 0, 0}, {0, -1, 0}, {0, 0, 1}},   /* -X_gl: right +Z_gl = -Y */
    [F_GL_PY] = {{0, 0, 1}, {1, 0, 0}, {0, 1, 0}},     /* +Y_gl = up: right +X, up -Z_gl = +Y */
    [F_GL_NY] = {{0, 0, -1}, {1, 0, 0}, {0, -1, 0}},   /* -Y_gl = down: up +Z_gl = -Y */
    [F_GL_PZ] = {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}},    /* +Z_gl = -Y: right +X, up +Z */
    [F_GL_NZ] = {{0, 1, 0}, {-1, 0, 0}, {0, 0, 1}},    /* -Z_gl = +Y: right -X, up +Z */
};

#define NO_FACE (-1)
static const int8_t cells_cross_h[3][4] = {{NO_FACE, F_TOP, NO_FACE, NO_FACE},
                                           {F_LEFT, F_FRONT, F_RIGHT, F_BACK},
                                           {NO_FACE, F_BOTTOM, NO_FACE, NO_FACE}};
static const int8_t cells_cross_v[4][3] = {{NO_FACE, F_TOP, NO_FACE},
                                           {F_LEFT, F_FRONT, F_RIGHT},
                                           {NO_FACE, F_BOTTOM, NO_FACE},
                                           {NO_FACE, F_BACK_V, NO_FACE}};
static const int8_t strip_order[6] = {F_FRONT, F_BACK, F_LEFT, F_RIGHT, F_TOP, F_BOTTOM};
static const int8_t gl_order[6] = {F_GL_PX, F_GL_NX, F_GL_PY, F_GL_NY, F_GL_PZ, F_GL_NZ};

/* Geometry of an image in a layout. Continuous pixel coordinates: pixel (i, j) covers
 * [i, i+1) x [j, j+1), its centre is (i + 0.5, j + 0.5). */
typedef struct geom {
    int32_t layout, w, h;
    int32_t n;                    /* face size (cubes, strips, OpenEXR cube) */
    int32_t cols, rows;           /* cells of a cross or strip */
    int8_t cell[6][6];            /* face in cell [row][col] or NO_FACE */
    int32_t face_col[F_COUNT], face_row[F_COUNT];
    double cx, cy, r;             /* probes: disc centre and radius, pixels */
} geom;

static envl_result geom_init(geom *g, int32_t layout, int32_t w, int32_t h)
{
    memset(g, 0, sizeof *g);
    g->layout = layout;
    g->w = w;
    g->h = h;
    memset(g->cell, NO_FACE, sizeof g->cell);
    for (int f = 0; f < F_COUNT; f++)
        g->face_col[f] = g->face_row[f] = -1;
    switch (layout) {
    case ENVL_LAYOUT_CROSS_H:
        g->cols = 4, g->rows = 3;
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 4; c++)
                g->cell[r][c] = cells_cross_h[r][c];
        break;
    case ENVL_LAYOUT_CROSS_V:
        g->cols = 3, g->rows = 4;
        for (int r = 0; r < 4; r++)
            for (int c = 0; c < 3; c++)
                g->cell[r][c] = cells_cross_v[r][c];
        break;
    case ENVL_LAYOUT_STRIP_H:
    case ENVL__LAYOUT_GL_STRIP:
        g->cols = 6, g->rows = 1;
        break;
    case ENVL_LAYOUT_STRIP_V:
        g->cols = 1, g->rows = 6;
        break;
    case ENVL_LAYOUT_ANGULAR:
    case ENVL_LAYOUT_MIRRORBALL:
        g->cx = 0.5 * w;
        g->cy = 0.5 * h;
        g->r = 0.5 * (w < h ? w : h);
        return ENVL_OK;
    case ENVL_LAYOUT_EXR_LATLONG:
        return ENVL_OK;
    case ENVL_LAYOUT_EXR_CUBE:
        g->n = w < h / 6 ? w : h / 6;
        if (g->n < 1 || w != g->n || h != 6 * g->n) /* more would be pixels no face reads */
            return envl__fail(ENVL_ERR_FORMAT,
                              "OpenEXR cube map of %d x %d pixels: needs N x 6N (N >= 1)",
                              (int)w, (int)h);
        return ENVL_OK;
    default:
        return envl__fail(ENVL_ERR_ARGUMENT, "layout %d cannot be converted here", (int)layout);
    }
    int32_t nw = w / g->cols, nh = h / g->rows;
    g->n = nw < nh ? nw : nh;
    if (g->n < 1)
        return envl__fail(ENVL_ERR_FORMAT, "%s of %d x %d pixels: needs %d x %d faces of at "
                                           "least one pixel",
                          envl_layout_name(layout), (int)w, (int)h, (int)g->cols, (int)g->rows);
    /* an image larger than the faces would have pixels no face reads: their light lost */
    if (w != g->cols * g->n || h != g->rows * g->n)
        return envl__fail(ENVL_ERR_FORMAT, "%s of %d x %d pixels: its %d x %d square faces "
                                           "must fill the image (faces of %d: %d x %d; of %d: "
                                           "%d x %d); the rest would be ignored",
                          envl_layout_name(layout), (int)w, (int)h, (int)g->cols, (int)g->rows,
                          (int)g->n, (int)(g->cols * g->n), (int)(g->rows * g->n),
                          (int)(g->n + 1), (int)(g->cols * (g->n + 1)),
                          (int)(g->rows * (g->n + 1)));
    if (layout == ENVL_LAYOUT_STRIP_H || layout == ENVL_LAYOUT_STRIP_V ||
        layout == ENVL__LAYOUT_GL_STRIP)
        for (int k = 0; k < 6; k++) {
            if (layout == ENVL_LAYOUT_STRIP_H)
                g->cell[0][k] = strip_order[k];
            else if (layout == ENVL__LAYOUT_GL_STRIP)
                g->cell[0][k] = gl_order[k];
            else
                g->cell[k][0] = strip_order[k];
        }
    for (int r = 0; r < g->rows; r++)
        for (int c = 0; c < g->cols; c++)
            if (g->cell[r][c] != NO_FACE) {
                g->face_col[g->cell[r][c]] = c;
                g->face_row[g->cell[r][c]] = r;
            }
    return ENVL_OK;
}

/* A position in the input: continuous pixel coordinates, the pixel rectangle bilinear taps are
 * clamped to, and the layout-local coordinates (a, b) that local_scale() reads: face s, t
 * (cubes), normalized disc x, y (probes), elevation (lat-long). */
typedef struct spos {
    double x, y;
    int32_t x0, y0, x1, y1;
    double a, b;
    int32_t face; /* our cubes: the face (F_*) */
} spos;

static void normalize3(double d[3])
{
    double l = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (l > 0)
        d[0] /= l, d[1] /= l, d[2] /= l;
}

static double clampd(double v, double lo, double hi) { return v < lo ? lo : v > hi ? hi : v; }

/* OpenEXR cube: face index (0..5 = +X,-X,+Y,-Y,+Z,-Z of OpenEXR's frame), local pixel position
 * (integer = pixel centre) -> canonical direction. See the comment block above. */
static void exr_cube_dir(int face, int32_t n, double px, double py, double d[3], double *s,
                         double *t)
{
    double m = n - 1;
    double pifx = 0, pify = 0;
    switch (face) {
    case 0: pifx = m - py, pify = px; break;
    case 1: pifx = m - py, pify = m - px; break;
    case 2: pifx = px, pify = m - py; break;
    case 3: pifx = px, pify = py; break;
    case 4: pifx = m - px, pify = m - py; break;
    default: pifx = px, pify = m - py; break;
    }
    double posx = n > 1 ? pifx / m * 2 - 1 : 0, posy = n > 1 ? pify / m * 2 - 1 : 0;
    double e[3];
    switch (face) {
    case 0: e[0] = 1, e[1] = posx, e[2] = posy; break;
    case 1: e[0] = -1, e[1] = posx, e[2] = posy; break;
    case 2: e[0] = posx, e[1] = 1, e[2] = posy; break;
    case 3: e[0] = posx, e[1] = -1, e[2] = posy; break;
    case 4: e[0] = posx, e[1] = posy, e[2] = 1; break;
    default: e[0] = posx, e[1] = posy, e[2] = -1; break;
    }
    d[0] = e[2], d[1] = e[0], d[2] = e[1]; /* canonical = (z, x, y) of OpenEXR */
    normalize3(d);
    *s = posx, *t = posy;
}

/* Direction -> position in the input image. Returns false if the direction is not covered. */
static bool dir_to_pos(const geom *g, const double d[3], spos *p)
{
    switch (g->layout) {
    case ENVL_LAYOUT_ANGULAR:
    case ENVL_LAYOUT_MIRRORBALL: {
        /* d_img = (-d.y, d.z, -d.x) */
        double ix = -d[1], iy = d[2], nx, ny;
        if (g->layout == ENVL_LAYOUT_ANGULAR) {
            double r = acos(clampd(d[0], -1, 1)) / ENVL_PI, s = sqrt(ix * ix + iy * iy);
            nx = s > 0 ? r * ix / s : r;
            ny = s > 0 ? r * iy / s : 0;
        } else {
            double hz = 1 - d[0], l = sqrt(ix * ix + iy * iy + hz * hz);
            nx = l > 1e-300 ? ix / l : 1;
            ny = l > 1e-300 ? iy / l : 0;
        }
        p->x = g->cx + nx * g->r;
        p->y = g->cy - ny * g->r;
        p->a = nx, p->b = ny;
        p->x0 = 0, p->y0 = 0, p->x1 = g->w, p->y1 = g->h;
        return true;
    }
    case ENVL_LAYOUT_EXR_LATLONG: {
        double lat = asin(clampd(d[2], -1, 1));
        double lon = (d[0] == 0 && d[1] == 0) ? 0 : atan2(d[1], d[0]);
        double px = g->w > 1 ? (lon / (-2 * ENVL_PI) + 0.5) * (g->w - 1) : 0;
        double py = g->h > 1 ? (lat / (-ENVL_PI) + 0.5) * (g->h - 1) : 0;
        p->x = px + 0.5, p->y = py + 0.5;
        p->a = lat, p->b = 0;
        p->x0 = 0, p->y0 = 0, p->x1 = g->w, p->y1 = g->h;
        return true;
    }
    case ENVL_LAYOUT_EXR_CUBE: {
        double e[3] = {d[1], d[2], d[0]}; /* OpenEXR's frame */
        double ax = fabs(e[0]), ay = fabs(e[1]), az = fabs(e[2]);
        int face;
        double u, v, m;
        if (ax >= ay && ax >= az) {
            face = e[0] > 0 ? 0 : 1, m = ax, u = e[1], v = e[2];
        } else if (ay >= az) {
            face = e[1] > 0 ? 2 : 3, m = ay, u = e[0], v = e[2];
        } else {
            face = e[2] > 0 ? 4 : 5, m = az, u = e[0], v = e[1];
        }
        if (m == 0)
            return false;
        int32_t n = g->n;
        double sm = n - 1;
        double pifx = (u / m + 1) / 2 * sm, pify = (v / m + 1) / 2 * sm, px, py;
        switch (face) {
        case 0: px = pify, py = sm - pifx; break;
        case 1: px = sm - pify, py = sm - pifx; break;
        case 2: px = pifx, py = sm - pify; break;
        case 3: px = pifx, py = pify; break;
        case 4: px = sm - pifx, py = sm - pify; break;
        default: px = pifx, py = sm - pify; break;
        }
        p->x = px + 0.5, p->y = face * n + py + 0.5;
        p->a = u / m, p->b = v / m;
        p->x0 = 0, p->x1 = n, p->y0 = face * n, p->y1 = face * n + n;
        return true;
    }
    default: { /* our cubes */
        double ax = fabs(d[0]), ay = fabs(d[1]), az = fabs(d[2]);
        int f;
        if (ax >= ay && ax >= az)
            f = d[0] > 0 ? F_FRONT : (g->layout == ENVL_LAYOUT_CROSS_V ? F_BACK_V : F_BACK);
        else if (ay >= az)
            f = d[1] > 0 ? F_LEFT : F_RIGHT;
        else
            f = d[2] > 0 ? F_TOP : F_BOTTOM;
        const double(*fr)[3] = face_frame[f];
        double dc = d[0] * fr[0][0] + d[1] * fr[0][1] + d[2] * fr[0][2];
        if (dc <= 0)
            return false;
        double s = (d[0] * fr[1][0] + d[1] * fr[1][1] + d[2] * fr[1][2]) / dc;
        double t = (d[0] * fr[2][0] + d[1] * fr[2][1] + d[2] * fr[2][2]) / dc;
        int32_t n = g->n, x0 = g->face_col[f] * n, y0 = g->face_row[f] * n;
        p->x = x0 + (s + 1) * 0.5 * n;
        p->y = y0 + (1 - t) * 0.5 * n;
        p->a = s, p->b = t;
        p->x0 = x0, p->y0 = y0, p->x1 = x0 + n, p->y1 = y0 + n;
        p->face = f;
        return true;
    }
    }
}

/* Pixel (i, j) of the layout image, offset (fx, fy) in [0, 1) within it -> direction, dw/dA
 * (up to a constant factor per layout), and the local coordinates for local_scale(). Returns
 * false for pixels outside the layout's coverage (empty cells of a cross, outside the disc). */
static bool pix_to_dir(const geom *g, int32_t i, int32_t j, double fx, double fy, double d[3],
                       double *jac, double *a, double *b)
{
    double x = i + fx, y = j + fy;
    switch (g->layout) {
    case ENVL_LAYOUT_ANGULAR:
    case ENVL_LAYOUT_MIRRORBALL: {
        double nx = (x - g->cx) / g->r, ny = (g->cy - y) / g->r, r2 = nx * nx + ny * ny;
        if (r2 > 1)
            return false;
        double di[3];
        if (g->layout == ENVL_LAYOUT_ANGULAR) {
            double r = sqrt(r2), sr = sin(ENVL_PI * r);
            di[0] = r > 0 ? sr * nx / r : 0;
            di[1] = r > 0 ? sr * ny / r : 0;
            di[2] = -cos(ENVL_PI * r);
            *jac = r > 1e-12 ? sr / r : ENVL_PI; /* dw/dA = pi sin(pi r)/r, up to pi */
        } else {
            double nz = sqrt(fmax(0.0, 1 - r2));
            di[0] = 2 * nz * nx, di[1] = 2 * nz * ny, di[2] = 2 * nz * nz - 1;
            *jac = 1; /* dw/dA = 4, constant */
        }
        d[0] = -di[2], d[1] = -di[0], d[2] = di[1];
        normalize3(d);
        *a = nx, *b = ny;
        return true;
    }
    case ENVL_LAYOUT_EXR_LATLONG: {
        double px = x - 0.5, py = y - 0.5;
        double lat = g->h > 1 ? -ENVL_PI * (py / (g->h - 1) - 0.5) : 0;
        double lon = g->w > 1 ? -2 * ENVL_PI * (px / (g->w - 1) - 0.5) : 0;
        d[0] = cos(lon) * cos(lat), d[1] = sin(lon) * cos(lat), d[2] = sin(lat);
        *jac = fabs(cos(lat));
        *a = lat, *b = 0;
        return true;
    }
    case ENVL_LAYOUT_EXR_CUBE: {
        int32_t face = j / g->n;
        if (face > 5 || i >= g->n)
            return false;
        double s, t;
        exr_cube_dir(face, g->n, x - 0.5, y - 0.5 - face * g->n, d, &s, &t);
        *jac = pow(1 + s * s + t * t, -1.5);
        *a = s, *b = t;
        return true;
    }
    default: {
        int32_t n = g->n, col = i / n, row = j / n;
        if (col >= g->cols || row >= g->rows || g->cell[row][col] == NO_FACE)
            return false;
        const double(*fr)[3] = face_frame[g->cell[row][col]];
        double s = 2 * (x - col * n) / n - 1, t = 1 - 2 * (y - row * n) / n;
        for (int k = 0; k < 3; k++)
            d[k] = fr[0][k] + s * fr[1][k] + t * fr[2][k];
        normalize3(d);
        *jac = pow(1 + s * s + t * t, -1.5);
        *a = s, *b = t;
        return true;
    }
    }
}

/* Smallest and largest angle (radians) a step of one pixel of the layout image subtends at a
 * position with local coordinates (a, b). */
static void local_scale(const geom *g, double a, double b, double *amin, double *amax)
{
    double lo, hi;
    switch (g->layout) {
    case ENVL_LAYOUT_ANGULAR: {
        double r = sqrt(a * a + b * b);
        double radial = ENVL_PI / g->r;
        double tang = r > 1e-9 ? sin(ENVL_PI * fmin(r, 1.0)) / (r * g->r) : radial;
        lo = fmin(radial, tang), hi = fmax(radial, tang);
        break;
    }
    case ENVL_LAYOUT_MIRRORBALL: {
        double c = sqrt(fmax(0.0, 1 - (a * a + b * b)));
        double radial = c > 1e-9 ? 2 / (g->r * c) : ENVL_PI, tang = 2 * c / g->r;
        lo = fmin(radial, tang), hi = fmin(ENVL_PI, fmax(radial, tang));
        break;
    }
    case ENVL_LAYOUT_EXR_LATLONG: {
        double vert = g->h > 1 ? ENVL_PI / (g->h - 1) : ENVL_PI;
        double horiz = (g->w > 1 ? 2 * ENVL_PI / (g->w - 1) : 2 * ENVL_PI) * fabs(cos(a));
        lo = fmin(vert, horiz), hi = fmax(vert, horiz);
        break;
    }
    default: { /* cubes: rates of normalize(c + s rt + t up) */
        double step = g->layout == ENVL_LAYOUT_EXR_CUBE ? (g->n > 1 ? 2.0 / (g->n - 1) : 2.0)
                                                          : 2.0 / g->n;
        double q = 1 + a * a + b * b;
        double rs = sqrt(1 + b * b) / q, rt = sqrt(1 + a * a) / q;
        lo = step * fmin(rs, rt), hi = step * fmax(rs, rt);
        break;
    }
    }
    *amin = lo > 1e-12 ? lo : 1e-12;
    *amax = hi;
}

static int32_t sub_count(double out_angle, double in_angle)
{
    double n = ceil(out_angle / in_angle);
    return n < 2 ? 2 : n > ENVL_LAYOUT_MAX_SUB ? ENVL_LAYOUT_MAX_SUB : (int32_t)n;
}

static const float *pixel_at(const envl_image *src, int32_t i, int32_t j)
{
    return src->px + 3 * ((size_t)j * src->width + i);
}

/* Bilinear sample with every tap clamped to p's rectangle. */
static void sample_clamped(const envl_image *src, const spos *p, double out[3])
{
    double x = clampd(p->x, p->x0 + 0.5, p->x1 - 0.5) - 0.5;
    double y = clampd(p->y, p->y0 + 0.5, p->y1 - 0.5) - 0.5;
    int32_t i0 = (int32_t)floor(x), j0 = (int32_t)floor(y);
    double tx = x - i0, ty = y - j0;
    int32_t i1 = i0 + 1 < p->x1 ? i0 + 1 : p->x1 - 1, j1 = j0 + 1 < p->y1 ? j0 + 1 : p->y1 - 1;
    const float *a = pixel_at(src, i0, j0), *b = pixel_at(src, i1, j0);
    const float *c = pixel_at(src, i0, j1), *e = pixel_at(src, i1, j1);
    for (int k = 0; k < 3; k++)
        out[k] = (1 - ty) * ((1 - tx) * a[k] + tx * b[k]) + ty * ((1 - tx) * c[k] + tx * e[k]);
}

/* Bilinear sample of src at position p.
 *  - Our cubes: a tap beyond the face's edge is the point one pixel further along the face's
 *    plane, projected onto the cube and sampled there (clamped within the face it lands on),
 *    so faces join without a half-pixel step at their edges.
 *  - Probes: taps whose centres are outside the disc are dropped, the others renormalized (the
 *    point is first kept half a pixel inside the rim).
 *  - OpenEXR layouts: clamped within the face / image (their outer pixel centres lie on the
 *    face edges and the poles, so clamping loses nothing). */
static void sample_layout(const envl_image *src, const geom *g, const spos *p, double out[3])
{
    bool probe = g->layout == ENVL_LAYOUT_ANGULAR || g->layout == ENVL_LAYOUT_MIRRORBALL;
    bool cube = g->layout == ENVL_LAYOUT_CROSS_V || g->layout == ENVL_LAYOUT_CROSS_H ||
                g->layout == ENVL_LAYOUT_STRIP_H || g->layout == ENVL_LAYOUT_STRIP_V;
    if (!probe && !cube) {
        sample_clamped(src, p, out);
        return;
    }
    double x = p->x, y = p->y;
    if (probe) {
        double dx = x - g->cx, dy = y - g->cy, rr = sqrt(dx * dx + dy * dy);
        double lim = g->r > 0.5 ? g->r - 0.5 : 0;
        if (rr > lim) {
            x = g->cx + (rr > 0 ? dx / rr * lim : 0);
            y = g->cy + (rr > 0 ? dy / rr * lim : 0);
        }
        x = clampd(x, 0.5, g->w - 0.5);
        y = clampd(y, 0.5, g->h - 0.5);
    } else {
        x = clampd(x, p->x0, p->x1);
        y = clampd(y, p->y0, p->y1);
    }
    x -= 0.5, y -= 0.5;
    int32_t i0 = (int32_t)floor(x), j0 = (int32_t)floor(y);
    double tx = x - i0, ty = y - j0;
    double wx[2] = {1 - tx, tx}, wy[2] = {1 - ty, ty};
    double acc[3] = {0, 0, 0}, wsum = 0, best = -1;
    int32_t bi = i0, bj = j0;
    for (int v = 0; v < 2; v++)
        for (int u = 0; u < 2; u++) {
            int32_t ti = i0 + u, tj = j0 + v;
            double wgt = wx[u] * wy[v];
            if (probe) {
                ti = ti < g->w ? ti : g->w - 1;
                tj = tj < g->h ? tj : g->h - 1;
                if (wgt > best)
                    best = wgt, bi = ti, bj = tj;
                double ex = ti + 0.5 - g->cx, ey = tj + 0.5 - g->cy;
                if (wgt <= 0 || ex * ex + ey * ey > g->r * g->r)
                    continue;
            } else if (wgt <= 0) {
                continue;
            }
            double val[3];
            if (cube && (ti < p->x0 || ti >= p->x1 || tj < p->y0 || tj >= p->y1)) {
                const double(*fr)[3] = face_frame[p->face];
                int32_t n = g->n;
                double s = 2 * (ti + 0.5 - p->x0) / n - 1, t = 1 - 2 * (tj + 0.5 - p->y0) / n;
                double d[3];
                for (int k = 0; k < 3; k++)
                    d[k] = fr[0][k] + s * fr[1][k] + t * fr[2][k];
                normalize3(d);
                spos q;
                if (!dir_to_pos(g, d, &q))
                    continue;
                sample_clamped(src, &q, val);
            } else {
                const float *q = pixel_at(src, ti, tj);
                val[0] = q[0], val[1] = q[1], val[2] = q[2];
            }
            acc[0] += wgt * val[0], acc[1] += wgt * val[1], acc[2] += wgt * val[2];
            wsum += wgt;
        }
    if (wsum > 0) {
        for (int k = 0; k < 3; k++)
            out[k] = acc[k] / wsum;
    } else { /* every tap outside the disc: the nearest pixel */
        const float *q = pixel_at(src, bi, bj);
        out[0] = q[0], out[1] = q[1], out[2] = q[2];
    }
}

/* Bilinear sample of row j of a canonical lat-long image at column x (centres on integers,
 * wrapping across the seam). */
static void sample_ll_row(const envl_image *ll, int32_t j, double x, double out[3])
{
    int32_t w = ll->width;
    double fx = floor(x), tx = x - fx;
    int32_t i0 = (int32_t)fmod(fx, (double)w);
    if (i0 < 0)
        i0 += w;
    int32_t i1 = i0 + 1 < w ? i0 + 1 : 0;
    const float *a = pixel_at(ll, i0, j), *b = pixel_at(ll, i1, j);
    for (int k = 0; k < 3; k++)
        out[k] = (1 - tx) * a[k] + tx * b[k];
}

/* Bilinear sample of a canonical lat-long image in direction d: wraps in azimuth; beyond the
 * outermost row's centres it interpolates over the pole, towards the same row half a turn
 * away (the pole itself, half a row beyond, gets the mean of the two). */
static void sample_latlong(const envl_image *ll, const double d[3], double out[3])
{
    int32_t w = ll->width, h = ll->height;
    double x, y, a[3], b[3];
    envl_latlong_pixel(w, h, d, &x, &y); /* pixel centres on integers */
    if (y < 0 || y > h - 1) {
        int32_t j = y < 0 ? 0 : h - 1;
        double t = y < 0 ? -y : y - (h - 1); /* 0 .. 0.5 */
        t = t > 0.5 ? 0.5 : t;
        sample_ll_row(ll, j, x, a);
        sample_ll_row(ll, j, x + 0.5 * w, b);
        for (int k = 0; k < 3; k++)
            out[k] = (1 - t) * a[k] + t * b[k];
        return;
    }
    int32_t j0 = (int32_t)floor(y), j1 = j0 + 1 < h ? j0 + 1 : h - 1;
    double ty = y - j0;
    sample_ll_row(ll, j0, x, a);
    sample_ll_row(ll, j1, x, b);
    for (int k = 0; k < 3; k++)
        out[k] = (1 - ty) * a[k] + ty * b[k];
}

static envl_result check_image(const envl_image *img, const char *what)
{
    if (!img || !img->px || img->width <= 0 || img->height <= 0)
        return envl__fail(ENVL_ERR_ARGUMENT, "%s: no image", what);
    return ENVL_OK;
}

/* ---- guessing and default sizes ---- */

/* OpenEXR's envmap attribute wins; otherwise the aspect ratio: 2:1 lat-long, 1:1 (at least 8
 * pixels wide) angular probe -- a square image is taken for an angular probe; mirror balls need
 * an explicit layout (--layout-in mirrorball) -- 3:4 vertical cross, 4:3 horizontal cross, 6:1
 * and 1:6 strips; anything else is read as a lat-long of unusual aspect (1 x 1, 8192 x 1 ...). */
int32_t envl__guess_layout(const envl_image *img)
{
    if (!img)
        return ENVL_LAYOUT_LATLONG;
    if (img->meta.envmap_layout == ENVL_LAYOUT_EXR_LATLONG ||
        img->meta.envmap_layout == ENVL_LAYOUT_EXR_CUBE)
        return img->meta.envmap_layout;
    int64_t w = img->width, h = img->height;
    if (w <= 0 || h <= 0)
        return ENVL_LAYOUT_LATLONG;
    if (w == 2 * h)
        return ENVL_LAYOUT_LATLONG;
    if (w == h && w >= 8)
        return ENVL_LAYOUT_ANGULAR;
    if (4 * w == 3 * h)
        return ENVL_LAYOUT_CROSS_V;
    if (3 * w == 4 * h)
        return ENVL_LAYOUT_CROSS_H;
    if (w == 6 * h)
        return ENVL_LAYOUT_STRIP_H;
    if (h == 6 * w)
        return ENVL_LAYOUT_STRIP_V;
    return ENVL_LAYOUT_LATLONG;
}

int32_t envl__default_latlong_width(const envl_image *src, int32_t layout)
{
    if (!src || src->width <= 0 || src->height <= 0)
        return 1;
    geom g;
    switch (layout) {
    case ENVL_LAYOUT_ANGULAR:
    case ENVL_LAYOUT_MIRRORBALL: {
        int32_t dia = src->width < src->height ? src->width : src->height;
        return 2 * dia;
    }
    case ENVL_LAYOUT_CROSS_V:
    case ENVL_LAYOUT_CROSS_H:
    case ENVL_LAYOUT_STRIP_H:
    case ENVL_LAYOUT_STRIP_V:
    case ENVL_LAYOUT_EXR_CUBE:
        if (geom_init(&g, layout, src->width, src->height) != ENVL_OK)
            return src->width; /* the conversion reports the error */
        return 4 * g.n;
    default: /* lat-long, OpenEXR lat-long */
        return src->width;
    }
}

double envl__layout_pixel_solid_angle(int32_t layout, int32_t w, int32_t h, int32_t i, int32_t j)
{
    if (w <= 0 || h <= 0 || i < 0 || j < 0 || i >= w || j >= h)
        return 0.0;
    if (layout == ENVL_LAYOUT_LATLONG)
        return envl_latlong_solid_angle(w, h, j);
    geom g;
    double d[3], jac, a, b;
    if (geom_init(&g, layout, w, h) != ENVL_OK || !pix_to_dir(&g, i, j, 0.5, 0.5, d, &jac, &a, &b))
        return 0.0;
    /* pix_to_dir's jac is dw/dA up to a constant of the layout; times that and the pixel's area */
    switch (layout) {
    case ENVL_LAYOUT_ANGULAR: /* dw/dA = pi sin(pi r) / r on the unit disc, radius g.r pixels */
        return ENVL_PI * jac / (g.r * g.r);
    case ENVL_LAYOUT_MIRRORBALL: /* dw/dA = 4 on the unit disc */
        return 4.0 * jac / (g.r * g.r);
    case ENVL_LAYOUT_EXR_LATLONG: /* cos(latitude) dlongitude dlatitude; samples on the edges
                                     (the seam twice, the poles): the trapezoid rule */
        return jac * (w > 1 ? 2 * ENVL_PI / (w - 1) * (i == 0 || i == w - 1 ? 0.5 : 1.0)
                            : 2 * ENVL_PI) *
               (h > 1 ? ENVL_PI / (h - 1) * (j == 0 || j == h - 1 ? 0.5 : 1.0) : ENVL_PI);
    case ENVL_LAYOUT_EXR_CUBE: { /* dA / (1 + s^2 + t^2)^(3/2), s and t in steps of 2 / (N - 1)
                                    from edge to edge: the trapezoid rule */
        if (g.n == 1)
            return jac * 4.0;
        double step = 2.0 / (g.n - 1);
        int32_t fi = i, fj = j % g.n;
        return jac * step * step * (fi == 0 || fi == g.n - 1 ? 0.5 : 1.0) *
               (fj == 0 || fj == g.n - 1 ? 0.5 : 1.0);
    }
    default: { /* our cubes: s and t in steps of 2 / N */
        double step = 2.0 / g.n;
        return jac * step * step;
    }
    }
}

/* ---- conversions ---- */

envl_result envl__layout_to_latlong(const envl_image *src, int32_t layout, int32_t out_width,
                                    envl_image *out)
{
    envl_result rc = check_image(src, "layout conversion");
    if (rc)
        return rc;
    if (!out || out_width <= 0)
        return envl__fail(ENVL_ERR_ARGUMENT, "layout conversion: bad output width %d",
                          (int)out_width);
    int32_t out_h = out_width / 2 > 0 ? out_width / 2 : 1;
    if (layout == ENVL_LAYOUT_LATLONG) {
        float *px = NULL;
        rc = envl__latlong_resample(src->px, src->width, src->height, out_width, out_h, 0.0, &px);
        if (rc)
            return rc;
        memset(out, 0, sizeof *out);
        out->px = px;
        out->width = out_width;
        out->height = out_h;
        out->meta = src->meta;
        return ENVL_OK;
    }
    geom g;
    rc = geom_init(&g, layout, src->width, src->height);
    if (rc)
        return rc;
    envl_image res = {0};
    rc = envl__image_alloc(&res, out_width, out_h, NULL, "lat-long output");
    if (rc)
        return rc;
    res.meta = src->meta;

    double dphi = 2 * ENVL_PI / out_width, dtheta = ENVL_PI / out_h;
    for (int32_t r = 0; r < out_h; r++) {
        /* the row spans z in [z_bot, z_top]; sub-rows are equal steps of z (equal solid angle) */
        double z_top = sin(ENVL_PI * (0.5 - (double)r / out_h));
        double z_bot = sin(ENVL_PI * (0.5 - (double)(r + 1) / out_h));
        double theta_c = ENVL_PI * (0.5 - (r + 0.5) / out_h);
        /* widest part of the row: the edge nearer the equator */
        double cos_w = fmax(cos(theta_c), fmax(sqrt(fmax(0, 1 - z_top * z_top)),
                                               sqrt(fmax(0, 1 - z_bot * z_bot))));
        for (int32_t c = 0; c < out_width; c++) {
            double d0[3];
            envl_latlong_direction(out_width, out_h, c, r, d0);
            spos p0;
            int32_t nx = 2, ny = 2;
            if (dir_to_pos(&g, d0, &p0)) {
                double amin, amax;
                local_scale(&g, p0.a, p0.b, &amin, &amax);
                nx = sub_count(dphi * cos_w, amin);
                ny = sub_count(dtheta, amin);
            }
            double acc[3] = {0, 0, 0};
            int32_t cnt = 0;
            for (int32_t b = 0; b < ny; b++) {
                double z = z_top + (z_bot - z_top) * (b + 0.5) / ny;
                double cz = sqrt(fmax(0.0, 1 - z * z));
                for (int32_t a = 0; a < nx; a++) {
                    double u = (c + (a + 0.5) / nx) / out_width;
                    double phi = ENVL_PI * (1 - 2 * u);
                    double d[3] = {cz * cos(phi), cz * sin(phi), z}, v[3] = {0, 0, 0};
                    spos p;
                    if (dir_to_pos(&g, d, &p))
                        sample_layout(src, &g, &p, v);
                    acc[0] += v[0], acc[1] += v[1], acc[2] += v[2];
                    cnt++;
                }
            }
            float *o = res.px + 3 * ((size_t)r * out_width + c);
            for (int k = 0; k < 3; k++)
                o[k] = (float)(acc[k] / cnt);
        }
    }
    memset(out, 0, sizeof *out);
    *out = res;
    return ENVL_OK;
}

envl_result envl__latlong_to_layout(const envl_image *latlong, int32_t layout, int32_t size,
                                    envl_image *out)
{
    envl_result rc = check_image(latlong, "layout conversion");
    if (rc)
        return rc;
    if (!out || size <= 0)
        return envl__fail(ENVL_ERR_ARGUMENT, "layout conversion: bad size %d", (int)size);
    /* the sides in 64 bits: 6 x size does not fit 32 */
    int64_t s = size, w64, h64;
    switch (layout) {
    case ENVL_LAYOUT_LATLONG:
    case ENVL_LAYOUT_EXR_LATLONG: w64 = s, h64 = s / 2 > 0 ? s / 2 : 1; break;
    case ENVL_LAYOUT_ANGULAR:
    case ENVL_LAYOUT_MIRRORBALL: w64 = h64 = s; break;
    case ENVL_LAYOUT_CROSS_V: w64 = 3 * s, h64 = 4 * s; break;
    case ENVL_LAYOUT_CROSS_H: w64 = 4 * s, h64 = 3 * s; break;
    case ENVL_LAYOUT_STRIP_H:
    case ENVL__LAYOUT_GL_STRIP: w64 = 6 * s, h64 = s; break;
    case ENVL_LAYOUT_STRIP_V:
    case ENVL_LAYOUT_EXR_CUBE: w64 = s, h64 = 6 * s; break;
    default:
        return envl__fail(ENVL_ERR_ARGUMENT, "layout conversion: unknown layout %d",
                          (int)layout);
    }
    const char *name = layout == ENVL__LAYOUT_GL_STRIP ? "cube faces" : envl_layout_name(layout);
    if (w64 > INT32_MAX || h64 > INT32_MAX)
        return envl__fail(ENVL_ERR_ARGUMENT, "layout conversion: %s of size %d would be %lld x "
                          "%lld pixels: a side does not fit 32 bits", name, (int)size,
                          (long long)w64, (long long)h64);
    if (w64 * h64 > ENVL_DEFAULT_MAX_PIXELS)
        return envl__fail(ENVL_ERR_LIMIT, "layout conversion: %s of size %d would be %lld x "
                          "%lld pixels: more than the limit of %lld", name, (int)size,
                          (long long)w64, (long long)h64, (long long)ENVL_DEFAULT_MAX_PIXELS);
    int32_t w = (int32_t)w64, h = (int32_t)h64;
    if (layout == ENVL_LAYOUT_LATLONG) {
        float *px = NULL;
        rc = envl__latlong_resample(latlong->px, latlong->width, latlong->height, w, h, 0.0,
                                    &px);
        if (rc)
            return rc;
        memset(out, 0, sizeof *out);
        out->px = px, out->width = w, out->height = h, out->meta = latlong->meta;
        return ENVL_OK;
    }
    geom g;
    rc = geom_init(&g, layout, w, h);
    if (rc)
        return rc;
    envl_image res = {0};
    rc = envl__image_alloc(&res, w, h, NULL, "layout output");
    if (rc)
        return rc;
    res.meta = latlong->meta;
    res.meta.envmap_layout = layout == ENVL_LAYOUT_EXR_LATLONG || layout == ENVL_LAYOUT_EXR_CUBE
                                 ? layout
                                 : 0;

    int32_t lw = latlong->width, lh = latlong->height;
    double pole_cos = sin(ENVL_PI / (2.0 * lh)); /* cos(elevation) at the pole rows' centres */
    for (int32_t j = 0; j < h; j++)
        for (int32_t i = 0; i < w; i++) {
            double d0[3], jac, a, b;
            if (!pix_to_dir(&g, i, j, 0.5, 0.5, d0, &jac, &a, &b))
                continue; /* outside the coverage: stays 0 */
            double amin, amax;
            local_scale(&g, a, b, &amin, &amax);
            /* input (lat-long) pixel: pi/H high, 2 pi cos(elevation)/W wide, at the elevation
             * of the footprint's part nearest a pole */
            double el = fmin(ENVL_PI / 2, fabs(asin(clampd(d0[2], -1, 1))) + amax);
            double in = fmin(ENVL_PI / lh, 2 * ENVL_PI * fmax(cos(el), pole_cos) / lw);
            int32_t n = sub_count(amax, in);
            double acc[3] = {0, 0, 0}, wsum = 0;
            for (int32_t sb = 0; sb < n; sb++)
                for (int32_t sa = 0; sa < n; sa++) {
                    double d[3], v[3];
                    if (!pix_to_dir(&g, i, j, (sa + 0.5) / n, (sb + 0.5) / n, d, &jac, &a, &b))
                        continue;
                    sample_latlong(latlong, d, v);
                    acc[0] += jac * v[0], acc[1] += jac * v[1], acc[2] += jac * v[2];
                    wsum += jac;
                }
            float *o = res.px + 3 * ((size_t)j * w + i);
            if (wsum > 0)
                for (int k = 0; k < 3; k++)
                    o[k] = (float)(acc[k] / wsum);
        }
    memset(out, 0, sizeof *out);
    *out = res;
    return ENVL_OK;
}

envl_result envl__latlong_to_faces(const envl_image *latlong, int32_t strip, int32_t face,
                                   float **out)
{
    *out = NULL;
    if (strip != ENVL_LAYOUT_STRIP_H && strip != ENVL__LAYOUT_GL_STRIP)
        return envl__fail(ENVL_ERR_ARGUMENT, "cube faces: layout %d is not a horizontal strip",
                          (int)strip);
    envl_image img = {0};
    envl_result rc = envl__latlong_to_layout(latlong, strip, face, &img);
    if (rc)
        return rc;
    size_t n = (size_t)face * face;
    float *f = malloc(sizeof(float) * 3 * 6 * n);
    if (!f) {
        envl__image_free(&img);
        return envl__fail(ENVL_ERR_MEMORY, "cube faces: out of memory");
    }
    envl__huge_pages(f, sizeof(float) * 3 * 6 * n);
    for (int k = 0; k < 6; k++)
        for (int32_t r = 0; r < face; r++)
            memcpy(f + 3 * (k * n + (size_t)r * face),
                   img.px + 3 * ((size_t)r * img.width + (size_t)k * face),
                   sizeof(float) * 3 * face);
    envl__image_free(&img);
    *out = f;
    return ENVL_OK;
}

/* ---- the texels of a product: a lat-long image or a strip of cube faces ---- */

void envl__texel_direction(int32_t layout, int32_t w, int32_t h, int32_t col, int32_t row,
                           double d[3])
{
    if (layout != ENVL_LAYOUT_STRIP_H) {
        envl_latlong_direction(w, h, col, row, d);
        return;
    }
    envl__face_direction(col / h, 2 * (col % h + 0.5) / h - 1, 1 - 2 * (row + 0.5) / h, d);
}

void envl__face_direction(int32_t face, double s, double t, double d[3])
{
    const double(*fr)[3] = face_frame[strip_order[face]];
    for (int k = 0; k < 3; k++)
        d[k] = fr[0][k] + s * fr[1][k] + t * fr[2][k];
    normalize3(d);
}

/* The solid angle of the part of a cube face (the plane at distance 1) below and left of
 * (s, t): atan2(s t, sqrt(1 + s^2 + t^2)); a rectangle's is the alternating sum over its
 * corners (exact). */
static double face_corner(double s, double t)
{
    return atan2(s * t, sqrt(1 + s * s + t * t));
}

double envl__texel_solid_angle(int32_t layout, int32_t w, int32_t h, int32_t col, int32_t row)
{
    if (layout != ENVL_LAYOUT_STRIP_H)
        return envl_latlong_solid_angle(w, h, row);
    int32_t i = col % h;
    double s0 = 2.0 * i / h - 1, s1 = 2.0 * (i + 1) / h - 1;
    double t0 = 1 - 2.0 * (row + 1) / h, t1 = 1 - 2.0 * row / h;
    return face_corner(s1, t1) - face_corner(s0, t1) - face_corner(s1, t0) +
           face_corner(s0, t0);
}

int32_t envl__footprint_subdivision(double texel, int32_t h)
{
    double n = ceil(4 * texel / (ENVL_PI / h));
    return n < 4 ? 4 : n > 64 ? 64 : (int32_t)n;
}

/* The pixel of a lat-long image that holds direction d (the brute force's lookup). */
static const float *nearest_pixel(const envl_image *ll, const double d[3])
{
    double x, y;
    envl_latlong_pixel(ll->width, ll->height, d, &x, &y);
    int64_t c = (int64_t)floor(x + 0.5) % ll->width, r = (int64_t)floor(y + 0.5);
    c += c < 0 ? ll->width : 0;
    r = r < 0 ? 0 : r >= ll->height ? ll->height - 1 : r;
    return pixel_at(ll, (int32_t)c, (int32_t)r);
}

void envl__texel_footprint_mean(const envl_image *latlong, int32_t layout, int32_t w, int32_t h,
                                int32_t col, int32_t row, int32_t n, double out[3])
{
    double acc[3] = {0, 0, 0}, wsum = 0;
    double z_top = sin(ENVL_PI * (0.5 - (double)row / h));
    double z_bot = sin(ENVL_PI * (0.5 - (double)(row + 1) / h));
    for (int32_t b = 0; b < n; b++)
        for (int32_t a = 0; a < n; a++) {
            double d[3], wgt = 1;
            if (layout == ENVL_LAYOUT_STRIP_H) {
                const double(*fr)[3] = face_frame[strip_order[col / h]];
                double s = 2 * (col % h + (a + 0.5) / n) / h - 1;
                double t = 1 - 2 * (row + (b + 0.5) / n) / h;
                for (int k = 0; k < 3; k++)
                    d[k] = fr[0][k] + s * fr[1][k] + t * fr[2][k];
                wgt = pow(1 + s * s + t * t, -1.5); /* dw/dA on the face */
            } else { /* equal steps of azimuth and of z: equal solid angles */
                double z = z_top + (z_bot - z_top) * (b + 0.5) / n, cz = sqrt(fmax(0, 1 - z * z));
                double phi = ENVL_PI * (1 - 2 * (col + (a + 0.5) / n) / w);
                d[0] = cz * cos(phi), d[1] = cz * sin(phi), d[2] = z;
            }
            const float *p = nearest_pixel(latlong, d);
            for (int k = 0; k < 3; k++)
                acc[k] += wgt * p[k];
            wsum += wgt;
        }
    for (int k = 0; k < 3; k++)
        out[k] = acc[k] / wsum;
}

void envl__strip_sample(const float *strip, int32_t face, const double d[3], double out[3])
{
    geom g;
    spos p;
    envl_image img = {.width = 6 * face, .height = face, .px = (float *)strip};
    out[0] = out[1] = out[2] = 0;
    if (geom_init(&g, ENVL_LAYOUT_STRIP_H, 6 * face, face) || !dir_to_pos(&g, d, &p))
        return;
    sample_layout(&img, &g, &p, out);
}

void envl__texel_taps(int32_t layout, int32_t w, int32_t h, const double d[3],
                      int32_t col[4], int32_t row[4], double weight[4])
{
    double x, y;
    int32_t x0 = 0, x1 = w, wrap = layout != ENVL_LAYOUT_STRIP_H;
    if (wrap) {
        envl_latlong_pixel(w, h, d, &x, &y); /* centres on integers */
        y = clampd(y, 0, h - 1);
    } else {
        geom g;
        spos p;
        if (geom_init(&g, ENVL_LAYOUT_STRIP_H, w, h) || !dir_to_pos(&g, d, &p)) {
            for (int k = 0; k < 4; k++)
                col[k] = row[k] = 0, weight[k] = k == 0;
            return;
        }
        x0 = p.x0, x1 = p.x1;
        x = clampd(p.x, p.x0 + 0.5, p.x1 - 0.5) - 0.5;
        y = clampd(p.y, p.y0 + 0.5, p.y1 - 0.5) - 0.5;
    }
    double fx = floor(x), fy = floor(y), tx = x - fx, ty = y - fy;
    for (int k = 0; k < 4; k++) {
        int32_t c = (int32_t)fx + (k & 1), r = (int32_t)fy + (k >> 1);
        if (wrap)
            c = ((c % w) + w) % w;
        else
            c = c < x0 ? x0 : c >= x1 ? x1 - 1 : c;
        col[k] = c;
        row[k] = r < 0 ? 0 : r >= h ? h - 1 : r;
        weight[k] = ((k & 1) ? tx : 1 - tx) * ((k >> 1) ? ty : 1 - ty);
    }
}

envl_result envl__faces_to_layout(const float *strip, int32_t face, int32_t layout,
                                  envl_image *out)
{
    memset(out, 0, sizeof *out);
    if (layout != ENVL_LAYOUT_STRIP_H && layout != ENVL_LAYOUT_CROSS_V &&
        layout != ENVL__LAYOUT_GL_STRIP)
        return envl__fail(ENVL_ERR_ARGUMENT, "cube faces: cannot lay them out as layout %d",
                          (int)layout);
    int32_t w = layout == ENVL_LAYOUT_CROSS_V ? 3 * face : 6 * face;
    int32_t h = layout == ENVL_LAYOUT_CROSS_V ? 4 * face : face;
    geom in, g;
    envl_result rc = geom_init(&in, ENVL_LAYOUT_STRIP_H, 6 * face, face);
    if (!rc)
        rc = geom_init(&g, layout, w, h);
    if (!rc)
        rc = envl__image_alloc(out, w, h, NULL, "cube faces");
    if (rc)
        return rc;
    if (layout == ENVL_LAYOUT_STRIP_H) { /* the strip itself: each texel lands on its own */
        memcpy(out->px, strip, sizeof(float) * 3 * (size_t)w * h);
        return ENVL_OK;
    }
    for (int32_t j = 0; j < h; j++)
        for (int32_t i = 0; i < w; i++) {
            double d[3], jac, a, b;
            spos p;
            if (!pix_to_dir(&g, i, j, 0.5, 0.5, d, &jac, &a, &b) || !dir_to_pos(&in, d, &p))
                continue; /* an empty cell of the cross: 0 */
            /* the centre lands on a texel's centre (up to rounding): that texel */
            int32_t x = (int32_t)clampd(floor(p.x), p.x0, p.x1 - 1);
            int32_t y = (int32_t)clampd(floor(p.y), p.y0, p.y1 - 1);
            memcpy(out->px + 3 * ((size_t)j * w + i), strip + 3 * ((size_t)y * 6 * face + x),
                   sizeof(float) * 3);
        }
    return ENVL_OK;
}

const char *envl_layout_name(int32_t layout)
{
    static const char *names[ENVL_LAYOUT_COUNT] = {
        "auto", "latlong", "angular", "mirrorball", "cross", "hcross", "hstrip", "vstrip",
        "exr-latlong", "exr-cube"};
    return layout >= 0 && layout < ENVL_LAYOUT_COUNT ? names[layout] : NULL;
}

int32_t envl_layout_from_name(const char *name)
{
    if (!name)
        return -1;
    for (int32_t i = 0; i < ENVL_LAYOUT_COUNT; i++)
        if (strcmp(name, envl_layout_name(i)) == 0)
            return i;
    if (strcmp(name, "vcross") == 0)
        return ENVL_LAYOUT_CROSS_V;
    return -1;
}
