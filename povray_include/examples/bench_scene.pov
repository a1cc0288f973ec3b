// envlight scene benchmark, scene (a) (scripts/scene_bench.py --host pov renders it; docs/pov_scenes.md): a matte sphere and a glossy sphere on a grey plane.
// The lighting comes from "lighting.inc", written by the script for each recipe and for the
// reference; it places the lights, the sky and any radiosity settings itself. Every object gets
// its ambient through EnvLight_Add_Ambient(T, Albedo), a no-op when the lighting declares no
// ambient (the reference, lights-only and radiosity recipes), so one scene serves them all.
//   Bench_Pass 0: the whole scene; 1: only the glossy sphere's highlights (the other objects
//              are black and invisible but still cast shadows); 2: an id mask (matte sphere
//              red, glossy sphere green, plane blue; emission only)
#version 3.7;
global_settings { assumed_gamma 1 ambient_light 0 }
#include "lighting.inc"
#include "envlight.inc"
#ifndef (Bench_Pass) #declare Bench_Pass = 0; #end

camera { location <0, 1.5, -4.2> look_at <0, 0.45, 0> angle 40 }

#declare Bench_Matte_Albedo = <0.8, 0.8, 0.8>;
#declare Bench_Floor_Albedo = <0.5, 0.5, 0.5>;
#declare Bench_Glossy_Albedo = <0.6, 0.6, 0.6>;
// POV-Ray's highlight: specular S (N.H)^(1 / roughness), from light sources only.
#declare Bench_Glossy_Specular = 0.5;
#declare Bench_Glossy_Roughness = 0.05;

#macro Bench_Plain(Albedo)
  texture { pigment { rgb Albedo } finish { ambient 0 emission 0 diffuse 1 } }
#end

#macro Bench_Id(C)
  texture { pigment { rgb C } finish { ambient 0 diffuse 0 emission 1 } }
#end

#declare Bench_Glossy = texture {
  pigment { rgb Bench_Glossy_Albedo }
  finish { ambient 0 emission 0 diffuse 1 specular Bench_Glossy_Specular
           roughness Bench_Glossy_Roughness }
};
#declare Bench_Highlight_Only = texture {
  pigment { rgb 0 }
  finish { ambient 0 emission 0 diffuse 0 specular Bench_Glossy_Specular
           roughness Bench_Glossy_Roughness }
};
#declare Bench_Black = texture { pigment { rgb 0 } finish { ambient 0 emission 0 diffuse 0 } };

#switch (Bench_Pass)
#case (0)
  sphere { <-0.65, 0.55, 0>, 0.55
           EnvLight_Add_Ambient(Bench_Plain(Bench_Matte_Albedo), Bench_Matte_Albedo) }
  sphere { <0.65, 0.55, 0>, 0.55 EnvLight_Add_Ambient(Bench_Glossy, Bench_Glossy_Albedo) }
  plane { y, 0 EnvLight_Add_Ambient(Bench_Plain(Bench_Floor_Albedo), Bench_Floor_Albedo) }
#break
#case (1)
  sphere { <-0.65, 0.55, 0>, 0.55 texture { Bench_Black } no_image }
  sphere { <0.65, 0.55, 0>, 0.55 texture { Bench_Highlight_Only } }
  plane { y, 0 texture { Bench_Black } no_image }
#break
#case (2)
  sphere { <-0.65, 0.55, 0>, 0.55 Bench_Id(<1, 0, 0>) }
  sphere { <0.65, 0.55, 0>, 0.55 Bench_Id(<0, 1, 0>) }
  plane { y, 0 Bench_Id(<0, 0, 1>) }
#break
#end
