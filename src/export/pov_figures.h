/* The in-scene error each POV-Ray recipe's header quotes (pov_recipe.c): written by
 * scripts/figures.py --write from docs/scene_bench_pov.json (scripts/scene_bench.py --host pov),
 * checked against it by the test py_figures. Do not edit by hand. */
#ifndef ENVL_POV_FIGURES_H
#define ENVL_POV_FIGURES_H

#define POV_FIGURE_DOME \
    "scenes (a), (b) on 13 maps: objects 3.2 % median, 7.3 % worst; plane 2.8 % median, 5.3 % " \
    "worst; 9-17x less POV-Ray CPU than the reference (scene bench of 2026-11-24)"
#define POV_FIGURE_SH \
    "scenes (a), (b) on 13 maps: objects 33.6 % median, 117.7 % worst; plane 13.9 % median, 42.6 " \
    "% worst; 66-88x less POV-Ray CPU than the reference (scene bench of 2026-11-24)"
#define POV_FIGURE_IMAGE_RADIOSITY \
    "scenes (a), (b) on 13 maps: objects 9.9 % median, 20.0 % worst; plane 3.8 % median, 15.9 % " \
    "worst; 8-11x less POV-Ray CPU than the reference (scene bench of 2026-11-24)"
#define POV_FIGURE_DOME_AMBIENT \
    "scenes (a), (b) on 13 maps: objects 9.3 % median, 85.4 % worst; plane 6.9 % median, 22.1 % " \
    "worst; 7-22x less POV-Ray CPU than the reference (scene bench of 2026-11-24)"

#endif
