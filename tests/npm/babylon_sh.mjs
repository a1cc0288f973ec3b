// What Babylon.js renders from an EXT_lights_image_based light's irradianceCoefficients and
// intensity, with Babylon's own code: the steps of its loader (loaders/glTF/2.0/Extensions/
// EXT_lights_image_based: SphericalHarmonics.FromArray, scaleInPlace(intensity),
// convertIrradianceToLambertianRadiance, SphericalPolynomial.FromHarmonics), then the uniforms
// its PBR material sets by default (preScaledHarmonics: SPHERICAL_HARMONICS, on by default in
// pbrBRDFConfiguration) put through its shader's computeEnvironmentIrradiance, whose expression
// is read from Babylon's shader source (ShadersInclude/harmonicsFunctions) and evaluated per
// channel. The result is the Lambertian radiance E(n) / pi at each direction n.
// stdin: {"coefficients": 9 x 3, "intensity": s, "directions": [[x, y, z], ...]}
// stdout: {"radiance": [[r, g, b], ...], "expression": the shader's expression}
import fs from "fs";
import path from "path";
import { pathToFileURL } from "url";

const core = path.join(process.env.ENVL_NODE_MODULES, "@babylonjs", "core");
const load = (file) => import(pathToFileURL(path.join(core, file)));
const { SphericalHarmonics, SphericalPolynomial } = await load("Maths/sphericalPolynomial.js");
const { harmonicsFunctions } = await load("Shaders/ShadersInclude/harmonicsFunctions.js");

// #ifdef SPHERICAL_HARMONICS: vec3 computeEnvironmentIrradiance(vec3 normal) {return ...;}
const source = harmonicsFunctions.shader;
const start = source.indexOf("return vSphericalL00");
if (start < 0) throw new Error("Babylon's harmonicsFunctions has no SH computeEnvironmentIrradiance");
const expression = source.slice(start + "return ".length, source.indexOf(";", start));
if (!/^[\sA-Za-z0-9_.*()+-]+$/.test(expression)) throw new Error(`unexpected shader text: ${expression}`);
const irradiance = new Function("h", "c", "normal",
  `return ${expression.replace(/vSphericalL(\w+)/g, "h.l$1[c]")};`);

const input = JSON.parse(fs.readFileSync(0, "utf8"));
const sh = SphericalHarmonics.FromArray(input.coefficients);
sh.scaleInPlace(input.intensity);
sh.convertIrradianceToLambertianRadiance();
const h = SphericalPolynomial.FromHarmonics(sh).preScaledHarmonics;
const radiance = input.directions.map(([x, y, z]) =>
  ["x", "y", "z"].map((c) => irradiance(h, c, { x, y, z })));
process.stdout.write(JSON.stringify({ radiance, expression }));
