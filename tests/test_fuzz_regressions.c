/* Inputs the fuzzers (fuzz/run.sh) once crashed on. Each must now give a definite answer (a
 * result code from the table) and, where the file is valid, the right image. */
#include "internal.h"
#include "check.h"

#define DIR ENVL_SOURCE_DIR "/tests/fuzz_regressions/"

/* OpenEXRCore 3.1.5 wrote through the NULL destination we left for a channel we do not use:
 * a 64 x 64 file with extra channels. Now every channel gets a destination. */
static void test_exr_unused_channel(void)
{
    envl_limits lim = {1 << 22, NULL, 0};
    envl_image img = {0};
    CHECK_OK(envl__read_image_file(DIR "exr_unused_channel_null_destination.exr", &lim, &img));
    CHECK(img.width == 64 && img.height == 64);
    int finite = 1;
    for (int i = 0; i < img.width * img.height * 3; i++)
        finite &= isfinite(img.px[i]);
    CHECK(finite);
    envl__image_free(&img);
}

int main(void)
{
    test_exr_unused_channel();
    return check_report("test_fuzz_regressions");
}
