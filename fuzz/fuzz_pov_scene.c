/* libFuzzer target for the POV-Ray scene reader (envlight pov --scene; src/pov_scene.c): any
 * bytes are scanned without a crash, and the counts it returns stay consistent. */
#include "pov_scene.h"

#include <stdint.h>
#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    pov_scene s;
    pov_scene_scan((const char *)data, size, &s);
    if (s.casters < 0 || s.casters > s.objects || (s.ground && s.ground_albedo < -1) ||
        (!s.ground && s.ground_albedo != -1))
        abort(); /* a reader bug: libFuzzer reports it as a crash */
    return 0;
}
