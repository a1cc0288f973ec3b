/* libFuzzer target for the image readers: the bytes go to one reader chosen at build time
 * (FUZZ_READER = envl__read_hdr, envl__read_exr, envl__read_pfm, or envl__read_image_memory for
 * detection), with a pixel limit low enough that no input can allocate past a few hundred MB.
 * A successful read is also turned into an envmap (sanitising, layout guess, resampling). */
#include "internal.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    envl_limits lim = {1 << 22, NULL, 0};
    envl_image img = {0};
    if (FUZZ_READER(data, size, "fuzz", &lim, &img) != ENVL_OK)
        return 0;
    if ((int64_t)img.width * img.height <= 1 << 16) {
        envl_envmap *m = NULL;
        envl_load_options o = {.width = 64, .threads = 1};
        if (envl__envmap_from_image(&img, &o, "fuzz", &m) == ENVL_OK)
            envl_envmap_free(m);
    } else {
        envl__image_free(&img);
    }
    return 0;
}
