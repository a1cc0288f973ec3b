// CSG on a checkered floor under a sky of the scene's own, written as POV-Ray users do:
// colors.inc names, declared textures, union / difference / intersection, a sky_sphere.
// No light of its own: env.inc lights it; the sky_sphere stays the backdrop.
#version 3.7;
global_settings { assumed_gamma 1.0 }

#include "colors.inc"
#include "env.inc"

camera {
  location <0, 2.2, -5>
  look_at <0, 0.7, 0>
  angle 45
}

sky_sphere {
  pigment {
    gradient y
    color_map { [0.0 color rgb <0.75, 0.85, 1.0>] [0.4 color rgb <0.25, 0.45, 0.85>] }
  }
}

#declare T_Check = texture {
  pigment { checker color rgb 0.6 color rgb 0.35 scale 0.5 }
  finish { ambient 0 diffuse 1 }
}
#declare T_Stone = texture { pigment { color Gray60 } finish { ambient 0 diffuse 1 } }
#declare T_Orange = texture { pigment { color rgb <0.9, 0.45, 0.1> } finish { ambient 0 diffuse 1 } }
#declare T_Shiny = texture {
  pigment { color rgb <0.2, 0.3, 0.6> }
  finish { ambient 0 diffuse 0.8 phong 0.6 phong_size 80 }
}

plane { y, 0 texture { T_Check } }

// a hollowed cube: a box less a sphere
difference {
  box { -0.6, 0.6 }
  sphere { 0, 0.78 }
  translate <-1.4, 0.6, 0.3>
  texture { T_Stone }
}

// a lens: two spheres intersected
intersection {
  sphere { <0, 0, -0.45>, 0.7 }
  sphere { <0, 0, 0.45>, 0.7 }
  rotate 90 * x
  translate <0, 0.25, -0.6>
  texture { T_Orange }
}

// a snowman: spheres merged, on a disc of the floor
union {
  sphere { <0, 0.4, 0>, 0.4 }
  sphere { <0, 1.0, 0>, 0.28 }
  sphere { <0, 1.4, 0>, 0.18 }
  translate <1.3, 0, 0.5>
  texture { T_Shiny }
}
