/* The tolerant scene reader behind `envlight pov --scene`: what a POV-Ray scene places and
 * uses, from the two example scenes and small scenes written here; bad files end with -1 or a
 * note, never a crash. */
#include "pov_scene.h"
#include "check.h"

#include <stdint.h>
#include <unistd.h>

/* Writes `text` to a scratch file and reads it back; the read must succeed. */
static pov_scene scene_n(const char *text, size_t n)
{
    const char *path = tmp_path("scene.pov");
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (f) {
        CHECK(fwrite(text, 1, n, f) == n);
        fclose(f);
    }
    pov_scene s;
    CHECK(pov_scene_read(path, &s) == 0);
    CHECK(memchr(s.note, 0, sizeof s.note) != NULL);
    return s;
}

static pov_scene scene(const char *text) { return scene_n(text, strlen(text)); }

static int has(const char *note, const char *part) { return strstr(note, part) != NULL; }

/* Reads ENVL_SOURCE_DIR/relative and checks every field against `want` (note: empty). */
static void check_file(const char *relative, pov_scene want)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", ENVL_SOURCE_DIR, relative);
    pov_scene s;
    CHECK(pov_scene_read(path, &s) == 0);
    CHECK(s.objects == want.objects && s.casters == want.casters);
    CHECK(s.glossy == want.glossy && s.radiosity == want.radiosity && s.sky == want.sky);
    CHECK(s.ground == want.ground && s.ground_height == want.ground_height);
    /* a literal albedo is the luminance of the colour; grey 0.5: the weights sum to 1 */
    CHECK_NEAR(s.ground_albedo, want.ground_albedo, 1e-12);
    CHECK(strcmp(s.note, "") == 0);
}

/* sphere_on_plane.pov: a matte sphere, a plane { y, 0 } with EnvLight_Diffuse_Texture(<0.5,
 * 0.5, 0.5>) and a sphere with a #declare'd texture of specular 0.4; the lights and the sky
 * come from env.inc, which is not followed, so radiosity and sky are 0. */
static void test_sphere_on_plane(void)
{
    check_file("povray_include/examples/sphere_on_plane.pov",
               (pov_scene){.objects = 3, .casters = 3, .glossy = 1, .ground = 1,
                           .ground_height = 0, .ground_albedo = 0.5});
}

/* bench_scene.pov places its objects only inside `#switch (Bench_Pass)`: three cases of three
 * objects each (two spheres and a plane; none has no_shadow, pass 1 hides two with no_image,
 * which still casts). A branch counts the objects it places and a conditional adds the most
 * any branch places, so the scene has 3 objects and 3 casters (one pass's worth), not 9.
 * Glossy: `specular Bench_Glossy_Specular` is an identifier, so > 0. Ground: case 0's
 * `plane { y, 0 ...}`; its colour goes through a macro with an identifier, so albedo -1.
 * Lights, sky and radiosity come from lighting.inc, not followed: 0. */
static void test_bench_scene(void)
{
    check_file("povray_include/examples/bench_scene.pov",
               (pov_scene){.objects = 3, .casters = 3, .glossy = 1, .ground = 1,
                           .ground_height = 0, .ground_albedo = -1});
}

/* The scenes written as users write them (povray_include/examples, the scene benchmark's). */
static void test_user_scenes(void)
{
    char path[4096];
    pov_scene s;
    snprintf(path, sizeof path, "%s/povray_include/examples/still_life.pov", ENVL_SOURCE_DIR);
    CHECK(pov_scene_read(path, &s) == 0 && !s.note[0]);
    /* a plane, two wall boxes, five objects, the shelf (a union) and the ball under it */
    CHECK(s.objects == 10 && s.casters == 10 && s.glossy && s.ground && !s.ground_box);
    CHECK(s.ground_albedo == -1 && !s.sky && !s.lights && !s.radiosity);
    CHECK(s.reflective && s.double_highlights == 1 && s.double_line == 27); /* T_Gold */
    CHECK(s.includes == 1 && !strcmp(s.include_name, "env.inc"));
    snprintf(path, sizeof path, "%s/povray_include/examples/interior_window.pov",
             ENVL_SOURCE_DIR);
    CHECK(pov_scene_read(path, &s) == 0 && !s.note[0]);
    /* the floor is a box (the ceiling slab is one too, smaller) */
    CHECK(s.objects == 6 && s.ground && s.ground_box && s.ground_height == 0);
    CHECK(s.glossy && !s.reflective && !s.double_highlights && !s.sky && s.includes == 1);
    snprintf(path, sizeof path, "%s/povray_include/examples/csg_sky.pov", ENVL_SOURCE_DIR);
    CHECK(pov_scene_read(path, &s) == 0 && !s.note[0]);
    CHECK(s.objects == 4 && s.casters == 4 && s.ground && !s.ground_box && s.sky);
    CHECK(s.glossy && !s.reflective && s.includes == 1); /* colors.inc is standard */
}

static void test_glossy(void)
{
    pov_scene s = scene("sphere { 0, 1 pigment { rgb 1 } finish { ambient 0 diffuse 0.8 } }\n");
    CHECK(s.glossy == 0 && s.objects == 1 && s.casters == 1 && s.ground == 0);
    CHECK(s.ground_albedo == -1 && s.radiosity == 0 && s.sky == 0 && !s.note[0]);

    CHECK(scene("sphere { 0, 1 finish { specular 0 } }").glossy == 0);
    CHECK(scene("sphere { 0, 1 finish { specular 0.0 roughness 0.1 } }").glossy == 0);
    CHECK(scene("sphere { 0, 1 finish { specular 0.4 } }").glossy == 1);
    CHECK(scene("sphere { 0, 1 finish { specular albedo 0.4 } }").glossy == 1);
    CHECK(scene("sphere { 0, 1 finish { specular S } }").glossy == 1);        /* identifier */
    CHECK(scene("sphere { 0, 1 finish { specular 0 * 2 } }").glossy == 1);    /* expression */
    CHECK(scene("sphere { 0, 1 finish { phong 0 } }").glossy == 0);
    CHECK(scene("sphere { 0, 1 finish { phong 0.0 phong_size 40 } }").glossy == 0);
    CHECK(scene("sphere { 0, 1 finish { phong 1 } }").glossy == 1);
    CHECK(scene("sphere { 0, 1 finish { phong .5 } }").glossy == 1);
    /* reflection forms */
    CHECK(scene("sphere { 0, 1 finish { reflection { 0 } } }").glossy == 0);
    CHECK(scene("sphere { 0, 1 finish { reflection 0 } }").glossy == 0);
    CHECK(scene("sphere { 0, 1 finish { reflection rgb 0 } }").glossy == 0);
    CHECK(scene("sphere { 0, 1 finish { reflection { rgb <0, 0, 0> } } }").glossy == 0);
    CHECK(scene("sphere { 0, 1 finish { reflection color rgb <0, 0, 0> } }").glossy == 0);
    CHECK(scene("sphere { 0, 1 finish { reflection { 0.05 } } }").glossy == 1);
    CHECK(scene("sphere { 0, 1 finish { reflection 0.2 } }").glossy == 1);
    CHECK(scene("sphere { 0, 1 finish { reflection rgb <0, 0, 0.1> } }").glossy == 1);
    CHECK(scene("sphere { 0, 1 finish { reflection { 0, 1 fresnel on } } }").glossy == 1);
    CHECK(scene("sphere { 0, 1 finish { reflection { 0, 0 falloff 2 } } }").glossy == 0);
    CHECK(scene("sphere { 0, 1 finish { reflection { R } } }").glossy == 1);
    /* metallic: alone it means 1 */
    CHECK(scene("sphere { 0, 1 finish { metallic 0 } }").glossy == 0);
    CHECK(scene("sphere { 0, 1 finish { metallic 0.5 } }").glossy == 1);
    CHECK(scene("sphere { 0, 1 finish { metallic } }").glossy == 1);
    /* a declared texture or finish still counts, placed or not */
    CHECK(scene("#declare T = texture { finish { specular 0.5 } };\n"
                "sphere { 0, 1 pigment { rgb 1 } }\n").glossy == 1);
    CHECK(scene("#declare F = finish { phong 1 }\n").glossy == 1);
    /* whole identifiers, case-sensitive; photons' `reflection on` is no finish */
    CHECK(scene("sphere { 0, 1 finish { Specular 1 SPECULAR 1 specular_x 1 phong_size 9 "
                "reflection_exponent 2 } }").glossy == 0);
    CHECK(scene("sphere { 0, 1 photons { target reflection on refraction off } }").glossy == 0);
}

static void test_ground(void)
{
    pov_scene s = scene("plane { y, 0 }");
    CHECK(s.ground == 1 && s.ground_height == 0 && s.ground_albedo == -1 && s.objects == 1);
    s = scene("plane { <0, 1, 0>, -1.5 pigment { rgb 0.3 } }");
    CHECK(s.ground == 1);
    CHECK_NEAR(s.ground_height, -1.5, 1e-15);
    CHECK_NEAR(s.ground_albedo, 0.3, 1e-12);
    s = scene("plane { +y, 2 }");
    CHECK(s.ground == 1 && s.ground_height == 2);
    s = scene("plane { <0, 2.5, 0>, H }"); /* a non-literal height reads as 0 */
    CHECK(s.ground == 1 && s.ground_height == 0);
    CHECK(scene("plane { -y, 0 }").ground == 0);
    CHECK(scene("plane { x, 0 }").ground == 0);
    CHECK(scene("plane { z, 0 }").ground == 0);
    CHECK(scene("plane { <0, -1, 0>, 0 }").ground == 0);
    CHECK(scene("plane { <0.1, 1, 0>, 0 }").ground == 0);
    CHECK(scene("plane { N, 0 }").ground == 0);
    /* declared, or inside a CSG: not a placed ground */
    s = scene("#declare Floor = plane { y, 0 }\n");
    CHECK(s.ground == 0 && s.objects == 0);
    s = scene("union { plane { y, 0 } sphere { 0, 1 } }");
    CHECK(s.ground == 0 && s.objects == 1);
    /* the first plane facing up wins */
    s = scene("plane { x, 5 } plane { y, -2 pigment { rgb 0.1 } } plane { y, 3 }");
    CHECK(s.ground == 1 && s.ground_height == -2 && s.objects == 3);
    CHECK_NEAR(s.ground_albedo, 0.1, 1e-12);
}

static void test_albedo(void)
{
    const double r = 0.2126, g = 0.7152, b = 0.0722;
    CHECK_NEAR(scene("plane { y, 0 pigment { rgb 0.5 } }").ground_albedo, 0.5, 1e-12);
    CHECK_NEAR(scene("plane { y, 0 pigment { color rgb <0.2, 0.4, 0.6> } }").ground_albedo,
               r * 0.2 + g * 0.4 + b * 0.6, 1e-12);
    CHECK_NEAR(scene("plane { y, 0 pigment { rgb <1, 0, 0> } }").ground_albedo, r, 1e-12);
    CHECK_NEAR(scene("plane { y, 0 texture { pigment { colour rgb <0, 1, 0> } } }").ground_albedo,
               g, 1e-12);
    CHECK_NEAR(scene("plane { y, 0 pigment { rgbf <0, 0, 1, 0.5> } }").ground_albedo, b, 1e-12);
    CHECK_NEAR(scene("plane { y, 0 EnvLight_Diffuse_Texture(<0.3, 0.3, 0.3>) }").ground_albedo,
               0.3, 1e-12);
    CHECK_NEAR(scene("plane { y, 0 EnvLight_Diffuse_Texture(0.5) }").ground_albedo, 0.5, 1e-12);
    /* the library's other macro: the albedo is its second argument */
    CHECK_NEAR(scene("plane { y, 0 EnvLight_Add_Ambient(texture { T }, <0.4, 0.4, 0.4>) }")
                   .ground_albedo, 0.4, 1e-12);
    /* srgb is gamma-encoded: 0.5 is ((0.5 + 0.055) / 1.055)^2.4 linear */
    CHECK_NEAR(scene("plane { y, 0 pigment { srgb 0.5 } }").ground_albedo,
               pow(0.555 / 1.055, 2.4), 1e-12);
    /* a negative literal (a pigment that takes light away) is albedo 0, with a note; the
     * fuzzer's find (CI, 2026-11-28): -5 was returned as it was, below the -1 "unknown" */
    pov_scene neg = scene("plane { y, 0 pigment { rgb -5 } }");
    CHECK(neg.ground == 1 && neg.ground_albedo == 0 && strstr(neg.note, "luminance -5"));
    CHECK(scene("plane { y, 0 pigment { rgb <1, -1, 0> } }").ground_albedo == 0);
    CHECK(scene("box { <-9, -1, -9>, <9, 0, 9> pigment { rgb -0.5 } }").ground_albedo == 0);
    /* above 1 as written: the include clamps it and says so */
    CHECK_NEAR(scene("plane { y, 0 pigment { rgb 2 } }").ground_albedo, 2, 1e-12);
    /* not literals: -1 */
    CHECK(scene("plane { y, 0 pigment { Grey } }").ground_albedo == -1);
    CHECK(scene("plane { y, 0 pigment { color Grey } }").ground_albedo == -1);
    CHECK(scene("plane { y, 0 pigment { checker rgb 1 rgb 0 } }").ground_albedo == -1);
    CHECK(scene("plane { y, 0 pigment { rgb 0.5 * 2 } }").ground_albedo == -1);
    CHECK(scene("plane { y, 0 EnvLight_Diffuse_Texture(A) }").ground_albedo == -1);
    CHECK(scene("plane { y, 0 texture { T } }").ground_albedo == -1);
    /* only inside the plane's block, only a ground */
    CHECK(scene("plane { y, 0 } sphere { 0, 1 pigment { rgb 0.5 } }").ground_albedo == -1);
    CHECK(scene("plane { x, 0 pigment { rgb 0.5 } }").ground_albedo == -1);
}

/* A floor made of a box: placed, literal corners, no transform of its own, at least 4 x wider
 * and deeper than high; the largest such box; a plane facing up wins over any box. */
static void test_ground_box(void)
{
    pov_scene s = scene("box { <-5, -0.2, -5>, <5, 0, 5> pigment { rgb 0.4 } }\n"
                        "sphere { <0, 1, 0>, 1 }\n");
    CHECK(s.ground == 1 && s.ground_box == 1 && s.ground_height == 0 && s.objects == 2);
    CHECK_NEAR(s.ground_albedo, 0.4, 1e-12);
    s = scene("box { <3, 1, 3>, <-3, 0.9, -3> }"); /* corners in any order: the top is 1 */
    CHECK(s.ground_box == 1 && s.ground_height == 1 && s.ground_albedo == -1);
    s = scene("box { -1, <1, 1, 1> }"); /* a cube is no floor */
    CHECK(s.ground == 0);
    CHECK(scene("box { <-5, 0, -0.5>, <5, 1, 0.5> }").ground == 0);   /* a wall */
    CHECK(scene("box { <-5, -1, -5>, <5, 0, 5> rotate 10 * x }").ground == 0);
    CHECK(scene("box { <-5, -1, -5>, <5, 0, 5> translate y }").ground == 0);
    CHECK(scene("box { <-5, -1, -5>, <5, 0, 5> texture { T rotate 20 * y } }").ground == 1);
    CHECK(scene("box { <-5, -1, -5>, <5, H, 5> }").ground == 0);        /* not literal */
    CHECK(scene("#declare F = box { <-5, -1, -5>, <5, 0, 5> }\nobject { F }").ground == 0);
    /* the largest wins: a table top, then the floor, then a shelf */
    s = scene("box { <-0.7, 0.7, -0.5>, <0.7, 0.76, 0.5> pigment { rgb 0.2 } }\n"
              "box { <-4, -0.1, -4>, <4, 0, 4> pigment { rgb 0.6 } }\n"
              "box { <-1, 1.5, -0.2>, <1, 1.52, 0.2> }\n");
    CHECK(s.ground_box == 1 && s.ground_height == 0 && s.objects == 3);
    CHECK_NEAR(s.ground_albedo, 0.6, 1e-12);
    /* a plane facing up, before or after, is the ground */
    s = scene("box { <-4, -0.1, -4>, <4, 0, 4> } plane { y, -1 pigment { rgb 0.3 } }");
    CHECK(s.ground == 1 && s.ground_box == 0 && s.ground_height == -1);
    CHECK_NEAR(s.ground_albedo, 0.3, 1e-12);
    s = scene("plane { y, -1 } box { <-4, -0.1, -4>, <4, 0, 4> pigment { rgb 0.3 } }");
    CHECK(s.ground_box == 0 && s.ground_height == -1 && s.ground_albedo == -1);
}

/* Light sources the scene places (they light it already) or only declares. */
static void test_lights(void)
{
    pov_scene s = scene("light_source { <1, 2, 3> rgb 1 }\nsphere { 0, 1 }\n");
    CHECK(s.lights == 1 && s.lights_declared == 0 && s.objects == 1 && s.casters == 1);
    s = scene("#declare L = light_source { <1, 2, 3> rgb 1 }\n"
              "union { light_source { 0, 1 } sphere { 0, 1 } }\n"
              "#if (A) light_source { y, 1 } #end\n"
              "#macro Lamp() light_source { x, 1 } #end\n");
    CHECK(s.lights == 2 && s.lights_declared == 1 && s.objects == 1);
    CHECK(scene("sphere { 0, 1 } // light_source { 0, 1 }\n").lights == 0);
}

/* A finish that reflects and has highlights (under a sky, its reflection holds them): counted,
 * the first one's line kept; either alone is not. */
static void test_reflective_highlights(void)
{
    pov_scene s = scene("sphere { 0, 1 }\n"
                        "sphere { 1, 1 finish { reflection { 0.7 metallic } } }\n"
                        "#declare Gold = texture {\n  pigment { rgb <1, 0.7, 0.2> }\n"
                        "  finish { specular 0.7 roughness 0.01 metallic\n"
                        "           reflection { 0.7 metallic } }\n}\n"
                        "torus { 1, 0.2 finish { phong 1 reflection 0.2 } }\n");
    CHECK(s.reflective == 1 && s.double_highlights == 2 && s.double_line == 5);
    s = scene("sphere { 0, 1 finish { specular 0.5 } } sphere { 1, 1 finish { reflection 0.3 } }");
    CHECK(s.reflective == 1 && s.double_highlights == 0 && s.double_line == 0);
    s = scene("sphere { 0, 1 finish { specular 0.5 reflection 0 } }");
    CHECK(s.reflective == 0 && s.double_highlights == 0);
    s = scene("sphere { 0, 1 finish { specular 0 phong 0 reflection { 0.5 } } }");
    CHECK(s.reflective == 1 && s.double_highlights == 0);
    /* photons' `reflection on` is no finish */
    s = scene("sphere { 0, 1 finish { specular 1 } photons { reflection on } }");
    CHECK(s.reflective == 0 && s.double_highlights == 0);
}

/* #include files other than POV-Ray's standard ones (their contents are not read). */
static void test_includes(void)
{
    pov_scene s = scene("#include \"colors.inc\"\n#include \"textures.inc\"\n"
                        "#include \"envlight.inc\"\n#include \"env.inc\"\n"
                        "#include \"my_objects.inc\"\n");
    CHECK(s.includes == 2 && !strcmp(s.include_name, "env.inc") && s.objects == 0);
    CHECK(scene("#include \"colors.inc\"\nsphere { 0, 1 }").includes == 0);
}

static void test_radiosity_and_sky(void)
{
    CHECK(scene("global_settings { assumed_gamma 1 radiosity { count 100 } }").radiosity == 1);
    CHECK(scene("global_settings { assumed_gamma 1 }").radiosity == 0);
    CHECK(scene("global_settings { EnvLight_Radiosity_Settings() }").radiosity == 1);
    CHECK(scene("global_settings { EnvLight_Radiosity_Residual_Settings() }").radiosity == 1);
    /* an object's own radiosity { importance } is no radiosity setting */
    CHECK(scene("sphere { 0, 1 radiosity { importance 0.5 } }").radiosity == 0);

    CHECK(scene("background { rgb <0.2, 0.3, 0.4> }").sky == 1);
    CHECK(scene("sky_sphere { pigment { rgb 1 } }").sky == 1);
    CHECK(scene("#include \"env.inc\"\nEnvLight_Sky()\n").sky == 1);
    CHECK(scene("#declare F = EnvLight_Sky_File; sphere { 0, 1 }").sky == 0);
    CHECK(scene("sphere { 0, 1 }").sky == 0);
}

static void test_shadows_and_declarations(void)
{
    pov_scene s = scene("sphere { 0, 1 no_shadow }\nbox { 0, 1 pigment { rgb 1 } no_shadow }\n"
                        "object { S no_shadow }\n");
    CHECK(s.objects == 3 && s.casters == 0);
    s = scene("sphere { 0, 1 no_shadow } box { 0, 1 } cone { 0, 1, y, 0 shadowless }");
    CHECK(s.objects == 3 && s.casters == 2); /* shadowless is a light's keyword */

    s = scene("#declare S = sphere { 0, 1 }\n"
              "#declare B = box { 0, 1 };\n"
              "#local U = union { object { S } object { B } }\n"
              "#declare R = 1.5;\n"
              "#declare V = <1, 2, 3>\n"
              "object { S }\n"
              "object { U no_shadow }\n"
              "#declare A = array[2] { sphere { 0, 1 }, box { 0, 1 } }\n"
              "#declare A[1] = torus { 1, 0.1 }\n"
              "#declare C = color rgb 1\n"
              "cylinder { 0, y, 1 }\n");
    CHECK(s.objects == 3 && s.casters == 2);
    CHECK(!s.note[0]);
    /* a declared value that is a conditional ends at its #end */
    s = scene("#declare O = #if (1) sphere { 0, 1 } #else box { 0, 1 } #end\nobject { O }\n");
    CHECK(s.objects == 1);
}

static void test_conditionals_and_macros(void)
{
    pov_scene s = scene("#if (A) sphere { 0, 1 } sphere { 1, 1 } #else box { 0, 1 } #end\n"
                        "torus { 1, 0.1 }\n");
    CHECK(s.objects == 3 && s.casters == 3);
    s = scene("#switch (P)\n#case (0) sphere { 0, 1 no_shadow } #break\n"
              "#case (1) box { 0, 1 } box { 1, 2 } #break\n#else disc { 0, y, 1 }\n#end\n");
    CHECK(s.objects == 2 && s.casters == 2);
    s = scene("#ifdef (X) #if (Y) sphere { 0, 1 } #elseif (Z) #else box { 0, 1 } box { 0, 2 } #end"
              " #end\n");
    CHECK(s.objects == 2);
    /* loops count their body once; macro bodies are not placed (no expansion) */
    s = scene("#declare I = 0;\n#while (I < 10) sphere { I * x, 0.1 } #declare I = I + 1; #end\n");
    CHECK(s.objects == 1 && !s.note[0]);
    s = scene("#macro M(R) sphere { 0, R finish { specular 1 } } #end\nM(1)\n");
    CHECK(s.objects == 0 && s.glossy == 1);
    s = scene("#macro EnvLight_Sky() #end\n");
    CHECK(s.sky == 0); /* a macro's name is no call */
    s = scene("#macro My_Sky() sky_sphere { S } #end\n");
    CHECK(s.sky == 1); /* a sky_sphere anywhere counts, even in a macro body */
}

static void test_comments_and_strings(void)
{
    pov_scene s = scene("// sphere { 0, 1 finish { specular 1 } } background { }\n"
                        "/* sky_sphere { } plane { y, 0 } */\n"
                        "#debug \"sky_sphere { phong 1 \\\" specular 1 } \"\n"
                        "text { ttf \"a.ttf\" \"sphere { } plane { y, 0 } /*\" 0.1, 0 }\n");
    CHECK(s.objects == 1 && s.glossy == 0 && s.sky == 0 && s.ground == 0);
    CHECK(strcmp(s.note, "") == 0);
    /* nested block comments: the inner close does not end the outer one */
    s = scene("/* outer /* inner */ sphere { 0, 1 } still the outer */ box { 0, 1 }\n");
    CHECK(s.objects == 1 && !s.note[0]);
    /* `//` inside a block comment means nothing */
    s = scene("/* // */ box { 0, 1 }\n");
    CHECK(s.objects == 1 && !s.note[0]);
}

static void test_problems(void)
{
    /* a missing file: -1, the note names it */
    const char *missing = tmp_path("no_such_scene.pov");
    unlink(missing);
    pov_scene s;
    CHECK(pov_scene_read(missing, &s) == -1);
    CHECK(has(s.note, missing) && has(s.note, "cannot open"));
    /* a directory: -1 */
    CHECK(pov_scene_read(ENVL_TEST_TMP, &s) == -1);
    CHECK(has(s.note, ENVL_TEST_TMP) && has(s.note, "directory"));
    /* more than 64 MiB (sparse): -1 before reading */
    const char *big = tmp_path("big.pov");
    FILE *f = fopen(big, "wb");
    CHECK(f != NULL);
    if (f)
        fclose(f);
    CHECK(truncate(big, (off_t)POV_SCENE_MAX_BYTES + 1) == 0);
    CHECK(pov_scene_read(big, &s) == -1);
    CHECK(has(s.note, big) && has(s.note, "64 MiB"));
    unlink(big);
    /* an empty file: read, nothing in it */
    s = scene("");
    CHECK(s.objects == 0 && s.casters == 0 && s.glossy == 0 && s.ground == 0);
    CHECK(s.ground_albedo == -1 && s.radiosity == 0 && s.sky == 0 && !s.note[0]);
    /* syntax problems: read (0), noted, what came before still counts */
    s = scene("box { 0, 1 }\nsphere { 0, 1\n");
    CHECK(s.objects == 2 && s.casters == 2);
    CHECK(strcmp(s.note, "line 2: '{' never closed") == 0);
    s = scene("box { 0, 1 }\n}\nsphere { 0, 1 }\n");
    CHECK(s.objects == 2);
    CHECK(strcmp(s.note, "line 2: '}' without a matching '{'") == 0);
    s = scene("sphere { 0, 1 }\n/* never closed\nbox { 0, 1 }\n");
    CHECK(s.objects == 1);
    CHECK(strcmp(s.note, "line 2: unterminated /* comment") == 0);
    s = scene("sphere { 0, 1 }\n#debug \"never closed\nbox { 0, 1 }\n");
    CHECK(s.objects == 1);
    CHECK(strcmp(s.note, "line 2: unterminated string") == 0);
    s = scene("#end\nsphere { 0, 1 }\n#if (1)\n");
    CHECK(s.objects == 1);
    CHECK(has(s.note, "line 1: #end without"));
    /* the first problem is the one kept */
    s = scene("}\n/* open");
    CHECK(strcmp(s.note, "line 1: '}' without a matching '{'") == 0);
}

/* Deep nesting and random bytes: no crash, no recursion, sane fields. */
static void check_sane(const pov_scene *s)
{
    CHECK(s->objects >= 0 && s->casters >= 0 && s->casters <= s->objects);
    CHECK(s->lights >= 0 && s->lights_declared >= 0 && s->includes >= 0);
    CHECK(s->double_highlights >= 0 && (s->double_highlights == 0) == (s->double_line == 0));
    CHECK(!s->double_highlights || s->reflective);
    CHECK(!s->ground_box || s->ground);
    CHECK(memchr(s->include_name, 0, sizeof s->include_name) != NULL);
    CHECK(s->ground_albedo == -1 || isfinite(s->ground_albedo));
    CHECK(isfinite(s->ground_height));
    CHECK(memchr(s->note, 0, sizeof s->note) != NULL);
}

static void test_hostile(void)
{
    size_t n = 1 << 20;
    char *buf = malloc(n);
    CHECK(buf != NULL);
    if (!buf)
        return;
    pov_scene s;
    memset(buf, '{', n);
    pov_scene_scan(buf, n, &s);
    CHECK(has(s.note, "never closed"));
    for (size_t i = 0; i + 4 <= n; i += 4)
        memcpy(buf + i, "/*  ", 4);
    pov_scene_scan(buf, n, &s);
    CHECK(has(s.note, "unterminated /* comment"));
    for (size_t i = 0; i + 8 <= n; i += 8)
        memcpy(buf + i, "#if (1) ", 8);
    pov_scene_scan(buf, n, &s);
    CHECK(has(s.note, "nested deeper"));
    check_sane(&s);
    pov_scene_scan(NULL, 0, &s);
    CHECK(s.objects == 0 && !s.note[0]);

    /* random bytes, and random POV-ish tokens, each through the file reader too */
    static const char *const words[] = {
        "{", "}", "(", ")", "<", ">", ",", ";", "/*", "*/", "//", "\"", "\\", "\n", "#declare ",
        "#local ", "#if ", "#else ", "#end ", "#switch ", "#case ", "#macro ", "=", "sphere ",
        "plane ", "y ", "-", "0 ", "0.5 ", "1e400 ", "pigment ", "rgb ", "specular ", "reflection ",
        "no_shadow ", "global_settings ", "radiosity ", "EnvLight_Diffuse_Texture", "object ",
        "EnvLight_Add_Ambient", "photons ", "metallic ", "srgb ", "\0", "\xff"};
    uint64_t state = 0x9E3779B97F4A7C15u;
    for (int round = 0; round < 400; round++) {
        size_t len = 0, want = (size_t)(round * 37 % 4000);
        while (len < want) {
            state = state * 6364136223846793005u + 1442695040888963407u;
            if (round % 2) {
                buf[len++] = (char)(state >> 56);
            } else {
                const char *w = words[(state >> 33) % (sizeof words / sizeof words[0])];
                size_t wl = w[0] ? strlen(w) : 1;
                if (len + wl > want)
                    break;
                memcpy(buf + len, w, wl);
                len += wl;
            }
        }
        pov_scene_scan(buf, len, &s);
        check_sane(&s);
        if (round % 50 == 0) {
            pov_scene r = scene_n(buf, len);
            CHECK(r.objects == s.objects && r.casters == s.casters && r.glossy == s.glossy);
            CHECK(strcmp(r.note, s.note) == 0);
        }
    }
    free(buf);
}

/* Inputs the fuzzer (fuzz/fuzz_pov_scene.c) once broke, in tests/fuzz_regressions/. */
static void test_fuzz_regressions(void)
{
    /* A mutated bench scene whose object statement starts in one #case and ends (its '}'
     * lost) in the next: it was counted as an object in one branch and a caster in the
     * other, 3 objects and 4 casters. */
    char path[4096];
    snprintf(path, sizeof path, "%s/tests/fuzz_regressions/pov_scene_statement_across_branches.pov",
             ENVL_SOURCE_DIR);
    pov_scene s;
    CHECK(pov_scene_read(path, &s) == 0);
    check_sane(&s);
    CHECK(s.objects == 3 && s.casters == 3);
    CHECK(has(s.note, "never closed"));
}

int main(void)
{
    test_sphere_on_plane();
    test_bench_scene();
    test_glossy();
    test_ground();
    test_albedo();
    test_radiosity_and_sky();
    test_ground_box();
    test_lights();
    test_reflective_highlights();
    test_includes();
    test_user_scenes();
    test_shadows_and_declarations();
    test_conditionals_and_macros();
    test_comments_and_strings();
    test_problems();
    test_hostile();
    test_fuzz_regressions();
    return check_report("test_pov_scene");
}
