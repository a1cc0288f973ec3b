/* The progress callback (envl_set_progress): fractions rising to 1 with named stages, and a
 * cancel at any step: ENVL_ERR_CANCELLED, nothing returned, nothing written (a file already
 * there kept as it was). envl_compute, envl_products_export, envl_lights_compute,
 * envl_envmap_load, envl_envmap_to_layout; and the polls inside a long step (issue 30, 4.4). */
#include "envlight.h"
#include "check.h"

#include <dirent.h>

typedef struct record {
    int calls, rising, cancel_at; /* cancel_at: the call that cancels (0: never) */
    int polls;                    /* calls repeating the last step (the polls inside it) */
    double last;
    char stages[1024], last_stage[96];
} record;

static int on_progress(void *user, double fraction, const char *stage)
{
    record *r = user;
    /* a long step's loops poll: the last step again, at most every 0.1 s (a slow machine or
     * a sanitizer makes some); they cancel as the step they repeat */
    if (r->calls && fraction == r->last && !strcmp(stage, r->last_stage)) {
        r->polls++;
        return r->cancel_at && r->calls >= r->cancel_at;
    }
    snprintf(r->last_stage, sizeof r->last_stage, "%s", stage);
    r->calls++;
    r->rising &= fraction >= r->last && fraction >= 0 && fraction <= 1;
    r->last = fraction;
    if (strlen(r->stages) + strlen(stage) + 3 < sizeof r->stages)
        strcat(strcat(r->stages, stage), "; ");
    return r->cancel_at && r->calls >= r->cancel_at;
}

static int files_in(const char *dir)
{
    DIR *d = opendir(dir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)))
        n += e->d_name[0] != '.' || strncmp(e->d_name, ".envl-", 6) == 0;
    if (d)
        closedir(d);
    return n;
}

int main(void)
{
    envl_sky_options so = {.width = 64}; /* small: each step is computed again to cancel it */
    envl_envmap *m;
    CHECK_OK(envl_envmap_sky(&so, &m));
    envl_request q = {.diffuse = 1, .irradiance_map = 1, .specular_chain = 1, .measure = 1};
    /* every step reported, rising, to 1 */
    record r = {.rising = 1};
    envl_set_progress(on_progress, &r);
    envl_products *p;
    CHECK_OK(envl_compute(m, &q, &p));
    printf("envl_compute: %d calls: %s\n", r.calls, r.stages);
    CHECK(r.rising && r.last == 1.0);
    CHECK(r.calls == 1 + 1 + 6 + 1 + 1); /* SH and lights, irradiance, 6 levels, measure, done */
    CHECK(strstr(r.stages, "specular level 6 of 6") != NULL);
    /* a cancel at each step: nothing returned */
    for (int at = 1; at <= r.calls; at++) {
        record c = {.rising = 1, .cancel_at = at};
        envl_set_progress(on_progress, &c);
        envl_products *none = (envl_products *)&c;
        CHECK_RC(envl_compute(m, &q, &none), ENVL_ERR_CANCELLED);
        CHECK(none == NULL && strstr(envl_last_error(), "cancelled") != NULL);
    }
    /* export: a cancel while writing leaves the folder as it was */
    const char *dir = ENVL_TEST_TMP "/progress_export";
    mkdir(dir, 0755);
    DIR *old = opendir(dir); /* emptied: an earlier run's files */
    for (struct dirent *e; old && (e = readdir(old));) {
        char path[1024];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        if (e->d_name[0] != '.')
            remove(path);
    }
    if (old)
        closedir(old);
    char json[1024];
    snprintf(json, sizeof json, "%s/prefilter.json", dir);
    FILE *f = fopen(json, "w");
    CHECK(f != NULL);
    if (f)
        fputs("kept\n", f), fclose(f);
    record c = {.rising = 1, .cancel_at = 3};
    envl_set_progress(on_progress, &c);
    CHECK_RC(envl_products_export(p, dir, &(envl_export_options){.format = "pfm"}),
             ENVL_ERR_CANCELLED);
    CHECK(files_in(dir) == 1);
    char got[16] = "";
    f = fopen(json, "r");
    if (f) {
        CHECK(fgets(got, sizeof got, f) != NULL);
        fclose(f);
    }
    CHECK(strcmp(got, "kept\n") == 0);
    /* and without a cancel every file is written */
    record w = {.rising = 1};
    envl_set_progress(on_progress, &w);
    CHECK_OK(envl_products_export(p, dir, &(envl_export_options){.format = "pfm"}));
    CHECK(w.rising && w.last == 1.0 && files_in(dir) == 1 + 1 + 6);
    envl_products_free(p);
    /* lights: a cancel at the takes */
    record l = {.rising = 1, .cancel_at = 2};
    envl_set_progress(on_progress, &l);
    envl_lights *ls = NULL;
    CHECK_RC(envl_lights_compute(m, &(envl_lights_options){.measure = 1}, &ls),
             ENVL_ERR_CANCELLED);
    CHECK(ls == NULL && strstr(l.stages, "takes") != NULL);
    /* load: reading, the canonical frame, done; a cancel at each: no map */
    const char *file = ENVL_TEST_TMP "/progress_load.hdr";
    envl_set_progress(NULL, NULL);
    CHECK_OK(envl_envmap_save(m, file, NULL));
    record ld = {.rising = 1};
    envl_set_progress(on_progress, &ld);
    envl_envmap *back = NULL;
    CHECK_OK(envl_envmap_load(file, NULL, &back));
    printf("envl_envmap_load: %d calls: %s\n", ld.calls, ld.stages);
    CHECK(ld.rising && ld.last == 1.0 && ld.calls == 3);
    CHECK(strstr(ld.stages, "reading the file") != NULL);
    envl_envmap_free(back);
    for (int at = 1; at <= 3; at++) {
        record cc = {.rising = 1, .cancel_at = at};
        envl_set_progress(on_progress, &cc);
        back = m;
        CHECK_RC(envl_envmap_load(file, NULL, &back), ENVL_ERR_CANCELLED);
        CHECK(back == NULL && cc.calls == at);
    }
    /* to_layout: the resampling, done; a cancel at each: no pixels */
    for (int layout = ENVL_LAYOUT_LATLONG; layout < ENVL_LAYOUT_COUNT; layout++) {
        record t = {.rising = 1};
        envl_set_progress(on_progress, &t);
        float *px = NULL;
        int32_t lw = 0, lh = 0;
        CHECK_OK(envl_envmap_to_layout(m, layout, 16, &px, &lw, &lh));
        CHECK(t.rising && t.last == 1.0 && t.calls == 2 && strstr(t.stages, "resampling to "));
        envl_free(px);
        for (int at = 1; at <= 2; at++) {
            record cc = {.rising = 1, .cancel_at = at};
            envl_set_progress(on_progress, &cc);
            px = (float *)&cc;
            CHECK_RC(envl_envmap_to_layout(m, layout, 16, &px, &lw, &lh), ENVL_ERR_CANCELLED);
            CHECK(px == NULL && cc.calls == at);
        }
    }
    /* inside one long step (the exact irradiance at 1024 normals of a 1024 x 512 map, a
     * second or more): the loops poll, and a cancel from a poll stops it (issue 30, 4.4) */
    envl_sky_options big = {.width = 1024};
    envl_envmap *b;
    CHECK_OK(envl_envmap_sky(&big, &b));
    double *dirs = malloc(sizeof(double) * 3 * 1024), *e = malloc(sizeof(double) * 3 * 1024);
    for (int i = 0; i < 1024; i++)
        envl_fibonacci_direction(i, 1024, dirs + 3 * i);
    record poll = {.rising = 1, .cancel_at = 1};
    envl_set_progress(on_progress, &poll);
    CHECK_RC(envl_irradiance_exact(b, 1024, dirs, e), ENVL_ERR_CANCELLED);
    CHECK(poll.calls == 1 && strstr(envl_last_error(), "cancelled during the computation"));
    envl_set_progress(NULL, NULL);
    free(dirs), free(e);
    envl_envmap_free(b);
    /* unset: the callback set before is called no more */
    record none = {.rising = 1};
    envl_set_progress(on_progress, &none);
    envl_set_progress(NULL, NULL);
    CHECK_OK(envl_lights_compute(m, NULL, &ls));
    CHECK(none.calls == 0);
    envl_lights_free(ls);
    envl_envmap_free(m);
    return check_report("test_progress");
}
