// envlight benchmark scene (povray_include/examples/bench_scene.py renders it; README.md,
// "Accuracy against time in POV-Ray"): a matte sphere and a glossy sphere on a grey plane.
// The lighting comes from "lighting.inc", written by the script for each case; it declares
//   Bench_Ambient 1: the generated include's SH ambient is added (EnvLight_Add_Ambient)
//   Bench_Pass    0: the whole scene; 1: only the glossy sphere's highlights (the other
//                 objects are black and invisible but still cast shadows); 2: an id mask
//                 (diffuse sphere red, glossy sphere green, plane blue, emission only)
// and places the lights, the sky and any radiosity settings itself.
#version 3.7;
global_settings { assumed_gamma 1 ambient_light 0 }
#include "lighting.inc"
#ifndef (Bench_Ambient) #declare Bench_Ambient = 0; #end
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

#macro Bench_Lit(T, Albedo)
  #if (Bench_Ambient) EnvLight_Add_Ambient(T, Albedo) #else texture { T } #end
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
  sphere { <-0.65, 0.55, 0>, 0.55 Bench_Lit(Bench_Plain(Bench_Matte_Albedo), Bench_Matte_Albedo) }
  sphere { <0.65, 0.55, 0>, 0.55 Bench_Lit(Bench_Glossy, Bench_Glossy_Albedo) }
  plane { y, 0 Bench_Lit(Bench_Plain(Bench_Floor_Albedo), Bench_Floor_Albedo) }
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
