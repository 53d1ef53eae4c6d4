#!/usr/bin/env bash
# Makes the README's figures, one per technique family (hard, PCSS, moment: mssm4, bitmask):
# a real HDR map (tests/data/envmaps) lighting a real mesh (tests/data/meshes) on a ground plane,
# rendered by the technique (penumbra evaluate --out-dir: frame.exr), beside its Embree truth
# (penumbra reference, the same size, samples and seed) and its error heat map against that truth
# (bench/crop_grid: one colour scale for all four figures, relative RMSE in each label).
#
# Usage (from the repository root, after building penumbra_cli and crop_grid):
#   tools/readme_figures.sh [BUILD_DIR] [OUT_DIR]
# BUILD_DIR defaults to build, OUT_DIR to docs/figures. SIZE (default 240x135), SPP (default 512)
# and CAMERA (ex,ey,ez,tx,ty,tz,fovy; default: the mesh and the shadow it casts) may be set in
# the environment; the defaults take about five minutes on two cores and keep each PNG under
# 150 KB. The truths are computed once and cached in a temporary directory.
set -euo pipefail

build=${1:-build}
out=${2:-docs/figures}
size=${SIZE:-240x135}
spp=${SPP:-512}
camera=${CAMERA:-4.0,3.2,4.4,-0.6,0.3,0.6,36}
scene=tests/data/meshes/good/WusonOBJ.obj
env=tests/data/envmaps/courtyard.exr
penumbra=$build/penumbra
grid=$build/bench/crop_grid
for tool in "$penumbra" "$grid"; do
  [[ -x $tool ]] || { echo "readme_figures: $tool not built (cmake --build $build --target penumbra_cli crop_grid)" >&2; exit 2; }
done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"
common=(--scene "$scene" --env "$env" --size "$size" --camera "$camera" --spp "$spp" --seed 1)

echo "readme_figures: Embree truth ($size, $spp spp)" >&2
"$penumbra" reference "${common[@]}" --out "$work/truth.exr" >&2
# The truth's own relative noise (from its two half sample sets, stored in its header): an error
# below about twice this is not resolved by this truth.
noise=$("$penumbra" compare "$work/truth.exr" "$work/truth.exr" | sed -n 's/.*"reference_noise": *\([0-9.e+-]*\).*/\1/p')
echo "readme_figures: the truth's own relative noise is $noise" >&2

techniques=(hard pcss mssm4 bitmask)
for t in "${techniques[@]}"; do
  echo "readme_figures: $t" >&2
  "$penumbra" evaluate "${common[@]}" --shadows "$t" --truth "$work/truths" --out-dir "$work/$t" \
    > "$work/$t.txt"
done

# One scale for all figures: the largest of the techniques' automatic scales.
scale=0
for t in "${techniques[@]}"; do
  s=$("$grid" --reference "$work/truth.exr" --out "$work/probe.png" "$t=$work/$t/frame.exr" |
      sed -n 's/.*scale \([0-9.e+-]*\)% of.*/\1/p')
  scale=$(awk -v a="$scale" -v b="$s" 'BEGIN { print (b > a ? b : a) }')
done
scale=$(awk -v s="$scale" 'BEGIN { print s / 100 }')

for t in "${techniques[@]}"; do
  "$grid" --reference "$work/truth.exr" --truth-column --scale "$scale" \
    --out "$out/technique-$t.png" "$t=$work/$t/frame.exr"
done
ls -l "$out"/technique-*.png >&2
