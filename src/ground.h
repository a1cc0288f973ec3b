/* The environment as a scene on a ground plane sees it (envlight pov --ground; ground.c). */
#ifndef ENVL_GROUND_H
#define ENVL_GROUND_H

#include "envlight.h"

/* A copy of `map` whose lower hemisphere (canonical z < 0) is the uniform radiance
 * albedo * E_up / pi of a Lambertian plane at z = 0, E_up the map's exact irradiance at the
 * normal +Z; ground_rgb (may be NULL) receives that radiance. albedo within [0, 1]. The copy is
 * a canonical lat-long map from memory (rotation already applied); release with
 * envl_envmap_free. */
envl_result envl_ground_plane_map(const envl_envmap *map, double albedo, int32_t threads,
                                  envl_envmap **out, double ground_rgb[3]);

/* A copy of `map` with its lower hemisphere black: the sky a scene on a ground plane sees
 * (envlight pov's dome takes its lights from it; ground.c). */
envl_result envl_sky_hemisphere_map(const envl_envmap *map, int32_t threads, envl_envmap **out);

#endif
