"""The in-scene error the panel quotes per recipe: written by scripts/figures.py --write from
docs/scene_bench_blender.json (scripts/scene_bench.py --host blender, 2026-11-27, 2026-11-29, 2026-11-30; Blender 4.3.2) and
docs/blender34/scene_bench_blender.json (legacy EEVEE, Blender 3.4.1, 2026-11-30), checked against them by the test
py_figures. Do not edit by hand: the median and worst, over the scenes and maps where the add-on
picked the recipe, of the converged error against Cycles path tracing (relative RMS)."""

BENCH_DATE = '2026-11-30'
BENCH_DATE_LEGACY = '2026-11-30'

EXPECTED_ERROR = {
    'eevee-dome-ground': (0.0787, 1.8476),
    'eevee-residual-ground': (0.1529, 6.9921),
    'sun-residual': (0.0000, 0.0189),
}
EXPECTED_ERROR_LEGACY = {
    'eevee-residual-ground': (0.1469, 6.9568),
}
