// A still life in the corner of a room, written as a POV-Ray user writes a scene: textures
// declared once, a floor plane, two walls made of boxes, no light of its own. env.inc
// (envlight pov MAP --scene still_life.pov -o env.inc) lights it.
#version 3.7;
global_settings { assumed_gamma 1.0 }

#include "env.inc"

camera {
  location <2.1, 2.1, -4.3>
  look_at <-0.35, 0.5, 0.3>
  angle 48
}

#declare T_Floor = texture { pigment { rgb <0.45, 0.42, 0.38> } finish { ambient 0 diffuse 1 } }
#declare T_Wall  = texture { pigment { rgb <0.75, 0.74, 0.70> } finish { ambient 0 diffuse 1 } }
#declare T_White = texture { pigment { rgb 0.8 } finish { ambient 0 diffuse 1 } }
#declare T_Blue  = texture { pigment { rgb <0.10, 0.22, 0.65> } finish { ambient 0 diffuse 1 } }
#declare T_Red   = texture { pigment { rgb <0.65, 0.08, 0.06> } finish { ambient 0 diffuse 1 } }
#declare T_Wood  = texture { pigment { rgb <0.42, 0.28, 0.16> } finish { ambient 0 diffuse 1 } }
#declare T_Gloss = texture {
  pigment { rgb <0.15, 0.45, 0.20> }
  finish { ambient 0 diffuse 1 specular 0.5 roughness 0.02 }
}
#declare T_Gold = texture {
  pigment { rgb <0.85, 0.62, 0.22> }
  finish { ambient 0 diffuse 0.2 specular 0.7 roughness 0.01 metallic
           reflection { 0.7 metallic } }
}

// the room: a floor, the back wall and the left wall
plane { y, 0 texture { T_Floor } }
box { <-2.0, 0, 1.4>, <2.5, 2.4, 1.6> texture { T_Wall } }
box { <-2.2, 0, -2.5>, <-2.0, 2.4, 1.6> texture { T_Wall } }

// the still life
sphere { <-0.9, 0.45, 0.6>, 0.45 texture { T_White } }
sphere { <0.25, 0.3, -0.75>, 0.3 texture { T_Gloss } }
torus { 0.32, 0.1 rotate 90 * x translate <0.1, 0.42, 0.55> texture { T_Gold } }
cylinder { <0.95, 0, 0.7>, <0.95, 0.95, 0.7>, 0.22 texture { T_Blue } }
box { <-0.3, 0, -0.3>, <0.3, 0.5, 0.3> rotate 25 * y translate <-0.55, 0, -0.6> texture { T_Red } }

// a shelf on the left wall, on two legs, and a ball under it
#declare Shelf = union {
  box { <-2.0, 0.9, -0.2>, <-1.3, 0.96, 1.4> }
  box { <-1.4, 0, -0.15>, <-1.34, 0.9, -0.09> }
  box { <-1.4, 0, 1.25>, <-1.34, 0.9, 1.31> }
}
object { Shelf texture { T_Wood } }
sphere { <-1.7, 0.22, 0.5>, 0.22 texture { T_White } }
