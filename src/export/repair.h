/* What the loader did to a file's values (envl_info: NaN and Inf, negative values filled from
 * the light around them; docs/methods.md, "Negative pixels"), as the JSON object "repair" and
 * as text, the same in every output: the command line's warnings and JSON, prefilter.json, the
 * glTF file's extras, the POV-Ray include's header. Compiled into the library and the command
 * line, like json.c. */
#ifndef ENVL_REPAIR_H
#define ENVL_REPAIR_H

#include "envlight.h"
#include "json.h"

#include <stddef.h>

/* The JSON object "repair" (docs/design.md, "JSON"). */
void repair_json(json_writer *j, const envl_info *in);
/* "12 pixels with NaN or Inf: NaN and -Inf set to 0, +Inf to 5 (the largest finite value)"
 * into buf; 0 when there were none (buf ""), else 1. */
int repair_nonfinite_text(char *buf, size_t n, const envl_info *in);
/* "136 pixels with negative values (down to -1539): filled from the light around them
 * (windows up to 8 px wide), moving 19.1 % of the power (luminance) and keeping the file's
 * signed sum[; N values with too little light around them set to 0, adding P % to the power]"
 * into buf; 0 when there were none (buf ""), else 1. */
int repair_negative_text(char *buf, size_t n, const envl_info *in);

#endif
