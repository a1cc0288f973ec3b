// envlight example: a sphere on a plane lit by an environment (README.md, "POV-Ray").
//   envlight pov MAP.hdr --scene sphere_on_plane.pov --sky --exposure auto -o env.inc
//   povray sphere_on_plane.pov +W640 +H480 +A0.1                       (sphere_on_plane.png)
//   povray sphere_on_plane.pov +W640 +H480 +A0.1 +FH Declare=EnvLight_Exposure=1
//                                              (sphere_on_plane.hdr, in the map's radiometry)
// env.inc places the lights and the sky and finds envlight.inc by itself; objects take the
// ambient (here: the ground's bounce) through EnvLight_Diffuse_Texture / EnvLight_Add_Ambient.
#version 3.7;
global_settings { assumed_gamma 1 ambient_light 0 }
#include "env.inc"

camera { location <0, 1.6, -5> look_at <0, 0.7, 0> angle 45 }

// matte white sphere and grey floor: lights + the ambient that follows the normal
sphere { <0, 1, 0>, 1 EnvLight_Diffuse_Texture(<0.8, 0.8, 0.8>) }
plane { y, 0 EnvLight_Diffuse_Texture(<0.5, 0.5, 0.5>) }

// a glossy red sphere: its own texture (highlights) plus the ambient for its colour
#declare Red = texture {
  pigment { rgb <0.7, 0.1, 0.1> }
  finish { ambient 0 emission 0 diffuse 1 specular 0.4 roughness 0.02 reflection { 0.05 } }
};
sphere { <1.8, 0.5, -0.6>, 0.5 EnvLight_Add_Ambient(Red, <0.7, 0.1, 0.1>) }
