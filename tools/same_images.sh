#!/usr/bin/env bash
# Renders one set of configurations with two penumbra CLIs and checks every pair of images is
# identical: every pixel and channel equal (OpenImageIO's idiff with zero tolerance), and
# `penumbra compare` max abs error 0: the check a change that must not move a pixel
# (a restructuring, a speed-up) runs before it lands.
#   tools/same_images.sh OLD_CLI NEW_CLI [WORKDIR]
# Every technique at its defaults, the options that change the frame's path (mip prefilter,
# front/back faces, upper bound, bent normals, a user light set, greedy and center-surround
# extraction, the SH9 ambient, an animation frame, `auto` mixing exact, filtered and hard lights,
# the GL path), on the built-in scene, 96x54.
set -euo pipefail
old=$1 new=$2 dir=${3:-$(mktemp -d)}
here=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$dir/old" "$dir/new"
base=(--size 96x54 --shadow-map-size 64)
configs=(
  "mssm4|--shadows mssm4"
  "mssm6|--shadows mssm6"
  "cssm|--shadows cssm"
  "pcss|--shadows pcss"
  "hard|--shadows hard"
  "brute|--shadows brute --brute-samples 8"
  "bitmask|--shadows bitmask --light-samples 128"
  "bitmask-hard|--shadows bitmask-hard"
  "area-approx|--shadows area-approx"
  "none|--shadows none"
  "mssm4-mip|--shadows mssm4 --prefilter mip"
  "cssm-mip|--shadows cssm --prefilter mip"
  "mssm4-frontback|--shadows mssm4 --front-back"
  "mssm6-upper|--shadows mssm6 --upper-bound"
  "bitmask-bent|--shadows bitmask-hard --bent-normals"
  "lightset|--shadows pcss --light-set $here/examples/lights/window_and_sun.json"
  "textured|--shadows brute --brute-samples 8 --light-set $here/examples/lights/lamp_and_stained_window.json"
  "greedy|--extract greedy"
  "center-surround|--extract center-surround"
  "sh9|--ambient sh9"
  "polygon|--light-shape polygon --shadows pcss"
  "frame3|--frames 3 --shadows mssm4"
  "auto-mixed|--shadows auto --auto-exact 2 --auto-filtered 3"
  "gl|--gl osmesa --shadows mssm4"
)
fail=0
for c in "${configs[@]}"; do
  name=${c%%|*}; args=${c#*|}
  case $args in *--light-set*) ;; *) args="--lights 8 $args" ;; esac
  for side in old new; do
    cli=$old; [ $side = new ] && cli=$new
    # shellcheck disable=SC2086
    "$cli" render "${base[@]}" $args --out "$dir/$side/$name.exr" >/dev/null 2>"$dir/$side/$name.err" \
      || { echo "$name: $side render failed: $(tail -1 "$dir/$side/$name.err")"; fail=1; continue 2; }
  done
  # --frames writes name_NNNN.exr; compare every file the old CLI wrote for this configuration
  for f in "$dir"/old/"$name"*.exr; do
    g="$dir/new/$(basename "$f")"
    out=$("$new" compare "$g" "$f" 2>&1) || { echo "$name: compare failed: $out"; fail=1; continue; }
    maxabs=$(echo "$out" | sed -n 's/.*max[_ ]abs[^0-9]*\([0-9.eE+-]*\).*/\1/p' | head -1)
    # numerically zero: the JSON may write 0 or 0.0
    if awk -v v="$maxabs" 'BEGIN { exit !(v != "" && v + 0 == 0) }' && idiff -fail 0 -warn 0 "$g" "$f" >/dev/null 2>&1; then echo "$(basename "$f" .exr): identical"; else echo "$(basename "$f" .exr): DIFFERS ($out)"; fail=1; fi
  done
done
exit $fail
