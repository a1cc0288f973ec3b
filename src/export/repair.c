/* What the loader did to a file's values, as JSON and text (see repair.h). */
#include "repair.h"

#include <stdio.h>

/* e as a percentage of base, in luminance (0 when base holds none). */
static double luminance_percent(const double e[3], const double base[3])
{
    double b = envl_luminance(base[0], base[1], base[2]);
    return b > 0 ? 100.0 * envl_luminance(e[0], e[1], e[2]) / b : 0.0;
}

void repair_json(json_writer *j, const envl_info *in)
{
    json_object(j, "repair");
    json_int(j, "nonfinite_pixels", in->nonfinite_pixels);
    json_number(j, "infinity_value", in->infinity_value);
    json_int(j, "negative_pixels", in->negative_pixels);
    json_number(j, "negative_min", in->negative_min);
    json_numbers(j, "signed_power", in->signed_power, 3);
    json_numbers(j, "filled_energy", in->filled_energy, 3);
    json_int(j, "fill_window", in->fill_window);
    json_int(j, "unfilled_values", in->unfilled_values);
    json_numbers(j, "added_energy", in->added_energy, 3);
    json_object_end(j);
}

int repair_nonfinite_text(char *buf, size_t n, const envl_info *in)
{
    buf[0] = 0;
    if (!in->nonfinite_pixels)
        return 0;
    char infinity[80] = "";
    if (in->infinity_value > 0)
        snprintf(infinity, sizeof infinity, ", +Inf to %g (the largest finite value)",
                 in->infinity_value);
    snprintf(buf, n, "%lld pixels with NaN or Inf: NaN and -Inf set to 0%s",
             (long long)in->nonfinite_pixels, infinity);
    return 1;
}

int repair_negative_text(char *buf, size_t n, const envl_info *in)
{
    buf[0] = 0;
    if (!in->negative_pixels)
        return 0;
    char filled[160] = "", unfilled[160] = "";
    if (in->fill_window)
        snprintf(filled, sizeof filled, "filled from the light around them (windows up to %d px "
                 "wide), moving %.3g %% of the power (luminance) and keeping the file's signed "
                 "sum", in->fill_window, luminance_percent(in->filled_energy, in->signed_power));
    if (in->unfilled_values)
        snprintf(unfilled, sizeof unfilled, "%lld values with too little light around them set "
                 "to 0, adding %.3g %% to the power", (long long)in->unfilled_values,
                 luminance_percent(in->added_energy, in->signed_power));
    snprintf(buf, n, "%lld pixels with negative values (down to %g): %s%s%s",
             (long long)in->negative_pixels, in->negative_min, filled,
             *filled && *unfilled ? "; " : "", unfilled);
    return 1;
}
