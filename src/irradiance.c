/* The exact irradiance integrator (the reference for every approximation) and the error
 * measure of DESIGN.md. */
#include "envmap_impl.h"

#include <math.h>
#include <pthread.h>
#include <stdlib.h>

/* E(n) = sum_pixels L dw max(0, n.d). With d = (cos t cos p, cos t sin p, sin t):
 * n.d = cos t * (nx cos p + ny sin p) + nz sin t, so the per-column factor is computed once
 * per normal and each row adds one multiply-add per pixel. Row sums in double. */
static void irradiance_one(const envl_envmap *m, const double n[3], double *colfac,
                           double out[3])
{
    int32_t w = m->width, h = m->height;
    for (int32_t c = 0; c < w; c++)
        colfac[c] = n[0] * m->col_cos[c] + n[1] * m->col_sin[c];
    double acc[3] = {0, 0, 0};
    for (int32_t r = 0; r < h; r++) {
        double a = m->row_cos[r], b = n[2] * m->row_sin[r];
        double row[3] = {0, 0, 0};
        const float *p = m->px + (size_t)r * w * 3;
        for (int32_t c = 0; c < w; c++) {
            double t = a * colfac[c] + b;
            if (t > 0) {
                row[0] += t * p[3 * c];
                row[1] += t * p[3 * c + 1];
                row[2] += t * p[3 * c + 2];
            }
        }
        for (int k = 0; k < 3; k++)
            acc[k] += row[k] * m->row_omega[r];
    }
    for (int k = 0; k < 3; k++)
        out[k] = acc[k];
}

typedef struct {
    const envl_envmap *map;
    const double *normals;
    double *out;
    int32_t begin, end;
    int failed;
} irradiance_job;

static void *irradiance_worker(void *arg)
{
    irradiance_job *job = arg;
    double *colfac = malloc(sizeof(double) * job->map->width);
    if (!colfac) {
        job->failed = 1;
        return NULL;
    }
    for (int32_t i = job->begin; i < job->end; i++)
        irradiance_one(job->map, job->normals + 3 * i, colfac, job->out + 3 * i);
    free(colfac);
    return NULL;
}

envl_result envl_irradiance_exact(const envl_envmap *m, int32_t count, const double *normals,
                                  double *rgb_out)
{
    if (!m || count < 0 || (count && (!normals || !rgb_out)))
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_irradiance_exact: bad arguments");
    /* Each normal is computed by one thread from start to end: the result does not depend on
     * the thread count. */
    int32_t nt = m->threads < count ? m->threads : count;
    if (nt < 1)
        nt = 1;
    irradiance_job jobs[256];
    pthread_t tids[256];
    int started[256] = {0};
    for (int32_t t = 0; t < nt; t++) {
        jobs[t] = (irradiance_job){m, normals, rgb_out, (int32_t)((int64_t)count * t / nt),
                                   (int32_t)((int64_t)count * (t + 1) / nt), 0};
        if (t > 0)
            started[t] = pthread_create(&tids[t], NULL, irradiance_worker, &jobs[t]) == 0;
    }
    irradiance_worker(&jobs[0]);
    int failed = jobs[0].failed;
    for (int32_t t = 1; t < nt; t++) {
        if (started[t])
            pthread_join(tids[t], NULL);
        else
            irradiance_worker(&jobs[t]);
        failed |= jobs[t].failed;
    }
    return failed ? envl__fail(ENVL_ERR_MEMORY, "envl_irradiance_exact: out of memory")
                  : ENVL_OK;
}

/* Fibonacci sphere: z_i = 1 - (2i + 1)/n, phi_i = 2 pi i / golden ratio. */
void envl_fibonacci_direction(int32_t i, int32_t n, double d[3])
{
    const double golden = (1.0 + sqrt(5.0)) / 2.0;
    double z = 1.0 - (2.0 * i + 1.0) / n;
    double r = sqrt(fmax(0.0, 1.0 - z * z));
    double phi = 2.0 * ENVL_PI * fmod(i / golden, 1.0);
    d[0] = r * cos(phi);
    d[1] = r * sin(phi);
    d[2] = z;
}

double envl_relative_rms_luminance(int32_t count, const double *approx, const double *exact)
{
    if (count <= 0)
        return 0.0;
    double se = 0.0, sa = 0.0;
    for (int32_t i = 0; i < count; i++) {
        double ya = envl_luminance(approx[3 * i], approx[3 * i + 1], approx[3 * i + 2]);
        double ye = envl_luminance(exact[3 * i], exact[3 * i + 1], exact[3 * i + 2]);
        se += (ya - ye) * (ya - ye);
        sa += fabs(ye);
    }
    double rms = sqrt(se / count), mean = sa / count;
    /* No light at all: the error is 0 when the approximation is also dark, else infinite. */
    if (mean == 0.0)
        return rms == 0.0 ? 0.0 : INFINITY;
    return rms / mean;
}

envl_result envl_envmap_reference_irradiance(envl_envmap *m, const double **rgb_out)
{
    if (!m || !rgb_out)
        return envl__fail(ENVL_ERR_ARGUMENT, "envl_envmap_reference_irradiance: NULL argument");
    if (!m->reference) {
        double *normals = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
        double *ref = malloc(sizeof(double) * 3 * ENVL_ERROR_NORMALS);
        if (!normals || !ref) {
            free(normals);
            free(ref);
            return envl__fail(ENVL_ERR_MEMORY, "reference irradiance: out of memory");
        }
        for (int32_t i = 0; i < ENVL_ERROR_NORMALS; i++)
            envl_fibonacci_direction(i, ENVL_ERROR_NORMALS, normals + 3 * i);
        /* Maps wider than ENVL_REFERENCE_WIDTH are first resampled (exactly, by area) to that
         * width: the clamped cosine is smooth, so this changes E by at most ~4 pi h^2
         * relative (h = pi / 512: 1.5e-4), and keeps the reference fast for huge maps. */
        envl_envmap *small = NULL;
        envl_result rc = ENVL_OK;
        if (m->width > ENVL_REFERENCE_WIDTH) {
            float *px;
            int32_t w = ENVL_REFERENCE_WIDTH;
            int32_t h = (int32_t)fmax(1, llround((double)w * m->height / m->width));
            rc = envl__latlong_resample(m->px, m->width, m->height, w, h, 0.0, &px);
            if (rc == ENVL_OK) {
                envl_load_options lo = {.layout = ENVL_LAYOUT_LATLONG, .threads = m->threads};
                rc = envl_envmap_from_pixels(px, w, h, 3, &lo, &small);
                free(px);
            }
        }
        if (rc == ENVL_OK)
            rc = envl_irradiance_exact(small ? small : m, ENVL_ERROR_NORMALS, normals, ref);
        envl_envmap_free(small);
        free(normals);
        if (rc) {
            free(ref);
            return rc;
        }
        m->reference = ref;
    }
    *rgb_out = m->reference;
    return ENVL_OK;
}
