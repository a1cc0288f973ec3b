/* The loader's treatment of negative pixels: ringing filled from the light around it.
 *
 * Negative values in an HDR file are ringing: a resampling filter (Lanczos, sinc: a map resized
 * before it was saved) or a lossy codec's 8 x 8 DCT (DWAA / DWAB) overshoots around a bright
 * light. Both keep the local sum of light, so the positive values nearby, above all the bright
 * ones whose overshoot the negative lobes balance, hold what the negative ones lack; setting
 * negatives to 0 would add it back (a fifth of the power of a sunny map resized by a Lanczos
 * filter). Here each negative value is filled from the positive light around it instead, so the
 * sum of L dw stays the file's signed sum (docs/methods.md, "Negative pixels"; docs/design.md,
 * "Units").
 *
 * Per channel, over tiles of 8 x 8 pixels laid on the codec's block grid: a tile holding
 * negative values is filled from the smallest window of 1, 3 x 3, 5 x 5 or 9 x 9 tiles around
 * it (8 to 72 pixels; columns wrap across a lat-long map's seam) whose positive light
 * P = sum of L dw is at least 4 times its deficit D = sum of -L dw over its negative values.
 * Those become 0 and each positive value L gives min(c L, 1/2) of itself, c set so that the
 * gifts L dw min(c L, 1/2) sum to D: the window keeps its sum of L dw, a bright value gives the
 * largest fraction (the ringing is its overshoot), a dim sky beside a sun nearly nothing, and
 * no value loses more than half. A tile no window fits (a negative value with little light
 * around it: a dead pixel, noise about 0) has its negative values set to 0, and the light that
 * adds is reported. dw is the pixel's solid angle in the file's layout. */
#include "internal.h"

#include <math.h>
#include <stdlib.h>

#define TILE 8          /* the DCT block of DWAA / DWAB */
#define MIN_LIGHT 4.0   /* a window fits when its positive light is 4 x its deficit */
#define MAX_GIFT 0.5    /* the most of itself a value gives */
static const int32_t window_radius[] = {0, 1, 2, 4}; /* in tiles: 1, 3, 5, 9 tiles wide */
#define MAX_WINDOW (TILE * 9)

typedef struct tiles {
    float *px;
    int32_t w, h, layout;
    int32_t ox, oy;         /* the block grid's origin, 0..7: tile 1 starts there when nonzero */
    int32_t ntx, nty;
    int wrap;               /* lat-long: columns wrap */
    double *row_dw;         /* lat-long layouts: dw per row */
    float *px_dw;           /* the others: dw per pixel */
    /* per tile, of one channel: over its positive values the sums of L dw and L^2 dw and the
     * largest L; over its negative values the sum of -L dw and their count */
    double *pos, *sq, *top, *neg;
    int32_t *negatives;
    double (*gift)[2];      /* a window's positive values: L, L dw (MAX_WINDOW^2) */
} tiles;

static double pixel_dw(const tiles *t, int32_t i, int32_t j)
{
    return t->row_dw ? t->row_dw[j] : t->px_dw[(size_t)j * t->w + i];
}

/* Pixel range [*a, *b) of tile index k along an axis of n pixels whose grid starts at o. */
static void tile_span(int32_t k, int32_t o, int32_t n, int32_t *a, int32_t *b)
{
    int32_t start = o + TILE * (k - (o > 0)); /* tile 0 is [0, o) when o > 0 */
    *a = start < 0 ? 0 : start;
    *b = start + TILE > n ? n : start + TILE;
}

static int32_t tile_count(int32_t o, int32_t n)
{
    return (n - o + TILE - 1) / TILE + (o > 0);
}

static size_t tile_index(const tiles *t, int32_t cx, int32_t ty)
{
    int32_t tx = ((cx % t->ntx) + t->ntx) % t->ntx;
    return (size_t)ty * t->ntx + tx;
}

/* Sums of channel ch over tile (tx, ty) into the tables. */
static void sum_tile(tiles *t, int ch, int32_t tx, int32_t ty)
{
    int32_t x0, x1, y0, y1;
    tile_span(tx, t->ox, t->w, &x0, &x1);
    tile_span(ty, t->oy, t->h, &y0, &y1);
    double pos = 0.0, sq = 0.0, top = 0.0, neg = 0.0;
    int32_t count = 0;
    for (int32_t j = y0; j < y1; j++)
        for (int32_t i = x0; i < x1; i++) {
            double v = t->px[3 * ((size_t)j * t->w + i) + ch];
            if (v > 0) {
                double e = v * pixel_dw(t, i, j);
                pos += e;
                sq += v * e;
                top = v > top ? v : top;
            } else if (v < 0) {
                neg -= v * pixel_dw(t, i, j);
                count++;
            }
        }
    size_t k = (size_t)ty * t->ntx + tx;
    t->pos[k] = pos, t->sq[k] = sq, t->top[k] = top, t->neg[k] = neg, t->negatives[k] = count;
}

/* A window: tile rows [r0, r1], tile columns [c0, c0 + nc) (modulo ntx when wrapping). */
typedef struct window {
    int32_t r0, r1, c0, nc;
} window;

static window window_of(const tiles *t, int32_t tx, int32_t ty, int32_t r)
{
    window win = {ty - r < 0 ? 0 : ty - r, ty + r >= t->nty ? t->nty - 1 : ty + r, 0, 0};
    if (t->wrap && 2 * r + 1 >= t->ntx) {
        win.c0 = 0, win.nc = t->ntx;
    } else if (t->wrap) {
        win.c0 = tx - r, win.nc = 2 * r + 1;
    } else {
        int32_t a = tx - r < 0 ? 0 : tx - r, b = tx + r >= t->ntx ? t->ntx - 1 : tx + r;
        win.c0 = a, win.nc = b - a + 1;
    }
    return win;
}

static int larger_first(const void *a, const void *b)
{
    double x = ((const double *)a)[0], y = ((const double *)b)[0];
    return x < y ? 1 : x > y ? -1 : 0;
}

/* The c whose gifts L dw min(c L, 1/2) over the window's positive values sum to D (> 0), given
 * P >= 2 D. Without the cap c = D / Q, Q = sum of L^2 dw; when that would cap the largest value,
 * the values sorted largest first: with the k largest capped D = A / 2 + c B, A their sum of
 * L dw, B the others' sum of L^2 dw; the k that holds (c L_k >= 1/2 > c L_k+1) gives c. */
static double gift_rate(tiles *t, int ch, window win, double deficit, double sq, double top)
{
    double c = deficit / sq;
    if (c * top <= MAX_GIFT)
        return c;
    size_t n = 0;
    for (int32_t y = win.r0; y <= win.r1; y++)
        for (int32_t x = win.c0; x < win.c0 + win.nc; x++) {
            size_t m = tile_index(t, x, y);
            int32_t x0, x1, y0, y1;
            tile_span((int32_t)(m % t->ntx), t->ox, t->w, &x0, &x1);
            tile_span(y, t->oy, t->h, &y0, &y1);
            for (int32_t j = y0; j < y1; j++)
                for (int32_t i = x0; i < x1; i++) {
                    double v = t->px[3 * ((size_t)j * t->w + i) + ch];
                    if (v > 0) {
                        t->gift[n][0] = v;
                        t->gift[n][1] = v * pixel_dw(t, i, j);
                        n++;
                    }
                }
        }
    qsort(t->gift, n, sizeof *t->gift, larger_first);
    double capped = 0.0, rest = sq;
    for (size_t k = 0; k < n; k++) {
        /* the k largest capped */
        c = (deficit - MAX_GIFT * capped) / rest;
        if (c * t->gift[k][0] <= MAX_GIFT)
            return c;
        capped += t->gift[k][1];
        rest -= t->gift[k][0] * t->gift[k][1];
        if (!(rest > 0))
            break;
    }
    return c; /* not reached with P >= 2 D */
}

/* In tile (tx, ty), channel ch: negative values to 0 (their -L dw added to *filled), positive
 * ones L to L (1 - min(c L, 1/2)). */
static void fill_tile(tiles *t, int ch, int32_t tx, int32_t ty, double c, double *filled)
{
    int32_t x0, x1, y0, y1;
    tile_span(tx, t->ox, t->w, &x0, &x1);
    tile_span(ty, t->oy, t->h, &y0, &y1);
    for (int32_t j = y0; j < y1; j++)
        for (int32_t i = x0; i < x1; i++) {
            float *v = t->px + 3 * ((size_t)j * t->w + i) + ch;
            if (*v < 0) {
                *filled -= *v * pixel_dw(t, i, j);
                *v = 0.0f;
            } else if (*v > 0 && c > 0) {
                double g = c * *v;
                *v = (float)(*v * (1.0 - (g < MAX_GIFT ? g : MAX_GIFT)));
            }
        }
}

/* Tile (tx, ty) of channel ch, which holds negative values: fills its smallest window that
 * fits, else sets them to 0. */
static void fill_from_window(tiles *t, int ch, int32_t tx, int32_t ty, envl_info *info)
{
    for (size_t q = 0; q < sizeof window_radius / sizeof *window_radius; q++) {
        window win = window_of(t, tx, ty, window_radius[q]);
        double pos = 0.0, sq = 0.0, top = 0.0, neg = 0.0;
        for (int32_t y = win.r0; y <= win.r1; y++)
            for (int32_t x = win.c0; x < win.c0 + win.nc; x++) {
                size_t m = tile_index(t, x, y);
                pos += t->pos[m], sq += t->sq[m], neg += t->neg[m];
                top = t->top[m] > top ? t->top[m] : top;
            }
        if (!(pos >= MIN_LIGHT * neg)) /* also true for neg 0: values without solid angle */
            continue;
        double c = neg > 0 ? gift_rate(t, ch, win, neg, sq, top) : 0.0, moved = 0.0;
        for (int32_t y = win.r0; y <= win.r1; y++)
            for (int32_t x = win.c0; x < win.c0 + win.nc; x++) {
                size_t m = tile_index(t, x, y);
                if (!t->negatives[m] && c == 0.0)
                    continue;
                fill_tile(t, ch, (int32_t)(m % t->ntx), y, c, &moved);
                sum_tile(t, ch, (int32_t)(m % t->ntx), y);
            }
        info->filled_energy[ch] += moved;
        int32_t width = TILE * (2 * window_radius[q] + 1);
        if (neg > 0 && width > info->fill_window)
            info->fill_window = width;
        return;
    }
    /* too little light around: the negative values become 0 */
    double added = 0.0;
    info->unfilled_values += t->negatives[(size_t)ty * t->ntx + tx];
    fill_tile(t, ch, tx, ty, 0.0, &added);
    info->added_energy[ch] += added;
    sum_tile(t, ch, tx, ty);
}

envl_result envl__fill_negatives(envl_image *img, int32_t layout, const char *file,
                                 envl_info *info)
{
    tiles t = {.px = img->px, .w = img->width, .h = img->height, .layout = layout};
    t.ox = ((img->meta.block_x0 % TILE) + TILE) % TILE;
    t.oy = ((img->meta.block_y0 % TILE) + TILE) % TILE;
    t.ntx = tile_count(t.ox, t.w);
    t.nty = tile_count(t.oy, t.h);
    t.wrap = layout == ENVL_LAYOUT_LATLONG || layout == ENVL_LAYOUT_EXR_LATLONG;
    size_t n = (size_t)t.ntx * t.nty, npx = (size_t)t.w * t.h;
    t.pos = malloc(n * sizeof *t.pos);
    t.sq = malloc(n * sizeof *t.sq);
    t.top = malloc(n * sizeof *t.top);
    t.neg = malloc(n * sizeof *t.neg);
    t.negatives = malloc(n * sizeof *t.negatives);
    t.gift = malloc((size_t)MAX_WINDOW * MAX_WINDOW * sizeof *t.gift);
    if (t.wrap) /* dw depends on the row alone */
        t.row_dw = malloc((size_t)t.h * sizeof *t.row_dw);
    else
        t.px_dw = malloc(npx * sizeof *t.px_dw);
    envl_result rc = ENVL_OK;
    if (!t.pos || !t.sq || !t.top || !t.neg || !t.negatives || !t.gift ||
        !(t.row_dw || t.px_dw)) {
        rc = envl__fail(ENVL_ERR_MEMORY, "%s: cannot allocate the tiles that fill negative "
                        "pixels", file);
        goto done;
    }
    for (int32_t j = 0; j < t.h; j++) {
        if (t.row_dw)
            t.row_dw[j] = envl__layout_pixel_solid_angle(layout, t.w, t.h, 0, j);
        else
            for (int32_t i = 0; i < t.w; i++)
                t.px_dw[(size_t)j * t.w + i] =
                    (float)envl__layout_pixel_solid_angle(layout, t.w, t.h, i, j);
    }
    /* the light the file holds, before anything moves */
    for (int c = 0; c < 3; c++)
        info->signed_power[c] = 0.0;
    for (int32_t j = 0; j < t.h; j++) {
        double row[3] = {0, 0, 0};
        for (int32_t i = 0; i < t.w; i++) {
            const float *p = t.px + 3 * ((size_t)j * t.w + i);
            double dw = pixel_dw(&t, i, j);
            for (int c = 0; c < 3; c++)
                row[c] += p[c] * dw;
        }
        for (int c = 0; c < 3; c++)
            info->signed_power[c] += row[c];
    }
    for (int ch = 0; ch < 3 && info->negative_pixels; ch++) {
        for (int32_t ty = 0; ty < t.nty; ty++)
            for (int32_t tx = 0; tx < t.ntx; tx++)
                sum_tile(&t, ch, tx, ty);
        for (int32_t ty = 0; ty < t.nty; ty++) /* scan order: the same result every run */
            for (int32_t tx = 0; tx < t.ntx; tx++)
                if (t.negatives[(size_t)ty * t.ntx + tx])
                    fill_from_window(&t, ch, tx, ty, info);
    }
done:
    free(t.pos), free(t.sq), free(t.top), free(t.neg), free(t.negatives), free(t.gift);
    free(t.row_dw), free(t.px_dw);
    return rc;
}
