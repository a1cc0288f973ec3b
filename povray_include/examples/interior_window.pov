// A room corner with a window: the floor is a box, the back wall has a window cut out of it
// (difference), half the room has a ceiling. A table and a vase. No light of its own.
#version 3.7;
global_settings { assumed_gamma 1.0 }

#include "env.inc"

camera {
  location <1.9, 1.4, -3.3>
  look_at <-0.3, 1.0, 0.9>
  angle 52
}

#declare T_Floor   = texture { pigment { rgb <0.55, 0.45, 0.35> } finish { ambient 0 diffuse 1 } }
#declare T_Plaster = texture { pigment { rgb <0.8, 0.78, 0.74> } finish { ambient 0 diffuse 1 } }
#declare T_Table   = texture { pigment { rgb <0.35, 0.22, 0.12> } finish { ambient 0 diffuse 1 } }
#declare T_Vase    = texture {
  pigment { rgb <0.7, 0.7, 0.75> }
  finish { ambient 0 diffuse 0.9 phong 0.4 phong_size 60 }
}

// the floor: a slab 20 cm thick, its top at y = 0
box { <-3, -0.2, -3>, <3, 0, 3> texture { T_Floor } }

// the back wall with a window, the left wall, a ceiling over the back half
difference {
  box { <-2.2, 0, 1.5>, <2.5, 2.6, 1.7> }
  box { <-0.9, 0.9, 1.4>, <0.7, 2.1, 1.8> }
  texture { T_Plaster }
}
box { <-2.4, 0, -2.0>, <-2.2, 2.6, 1.7> texture { T_Plaster } }
box { <-2.4, 2.6, 0.2>, <2.5, 2.75, 1.7> texture { T_Plaster } }

// a table and a vase on it
union {
  box { <-0.8, 0.7, -0.1>, <0.6, 0.76, 0.9> }
  cylinder { <-0.7, 0, 0>, <-0.7, 0.7, 0>, 0.04 }
  cylinder { <0.5, 0, 0>, <0.5, 0.7, 0>, 0.04 }
  cylinder { <-0.7, 0, 0.8>, <-0.7, 0.7, 0.8>, 0.04 }
  cylinder { <0.5, 0, 0.8>, <0.5, 0.7, 0.8>, 0.04 }
  texture { T_Table }
}
union {
  sphere { <0, 0.95, 0.4>, 0.19 }
  cylinder { <0, 0.76, 0.4>, <0, 1.25, 0.4>, 0.08 }
  texture { T_Vase }
}
