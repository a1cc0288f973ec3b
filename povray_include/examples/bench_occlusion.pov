// envlight scene benchmark, scene (b) (scripts/scene_bench.py --host pov): occlusion. A matte
// sphere (albedo 0.8) in a corner under an overhang: a wall behind it and a slab above it
// (albedo 0.5), on the grey plane (0.5) of scene (a). The camera is lower than scene (a)'s so
// that the sphere, the shadowed floor under the slab and the slab's underside are all seen.
// Lighting as in bench_scene.pov: "lighting.inc" places lights, sky and radiosity settings;
// every object gets its ambient through EnvLight_Add_Ambient (a no-op without an ambient).
//   Bench_Pass 0: the whole scene; 2: an id mask (sphere red, wall and slab green, plane blue)
#version 3.7;
global_settings { assumed_gamma 1 ambient_light 0 }
#include "lighting.inc"
#include "envlight.inc"
#ifndef (Bench_Pass) #declare Bench_Pass = 0; #end

camera { location <1.0, 0.7, -3.4> look_at <-0.15, 0.75, 0.4> angle 45 }

#declare Bench_Matte_Albedo = <0.8, 0.8, 0.8>;
#declare Bench_Floor_Albedo = <0.5, 0.5, 0.5>;
#declare Bench_Overhang_Albedo = <0.5, 0.5, 0.5>;

#macro Bench_Plain(Albedo)
  texture { pigment { rgb Albedo } finish { ambient 0 emission 0 diffuse 1 } }
#end

#macro Bench_Id(C)
  texture { pigment { rgb C } finish { ambient 0 diffuse 0 emission 1 } }
#end

// the sphere in the corner; the wall behind it (z 1.0 .. 1.2) and the slab above it
// (y 1.5 .. 1.65, reaching from the wall to z = -0.6)
#declare Bench_Object = sphere { <-0.5, 0.4, 0.5>, 0.4 };
#declare Bench_Overhang = union {
  box { <-1.5, 0, 1.0>, <0.9, 1.65, 1.2> }
  box { <-1.5, 1.5, -0.6>, <0.9, 1.65, 1.2> }
};

#switch (Bench_Pass)
#case (0)
  object { Bench_Object
           EnvLight_Add_Ambient(Bench_Plain(Bench_Matte_Albedo), Bench_Matte_Albedo) }
  object { Bench_Overhang
           EnvLight_Add_Ambient(Bench_Plain(Bench_Overhang_Albedo), Bench_Overhang_Albedo) }
  plane { y, 0 EnvLight_Add_Ambient(Bench_Plain(Bench_Floor_Albedo), Bench_Floor_Albedo) }
#break
#case (2)
  object { Bench_Object Bench_Id(<1, 0, 0>) }
  object { Bench_Overhang Bench_Id(<0, 1, 0>) }
  plane { y, 0 Bench_Id(<0, 0, 1>) }
#break
#end
