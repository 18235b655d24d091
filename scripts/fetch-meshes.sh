#!/usr/bin/env bash
# Download the reference meshes softbench's studies use from the public course repositories
# they come from, pinned to exact commits, and check every file's SHA-256.
#
#   scripts/fetch-meshes.sh [DEST]        (default DEST: ./meshes)
#   export SOFTBENCH_DATA="$PWD/meshes"
#
# Sources (no license was found in any of them; treat the files as third-party course material
# and do not redistribute them):
#   dilevin/CSC417-a3-finite-elements-3d  (University of Toronto, CSC417 assignment 3)
#   dilevin/CSC417-a2-mass-spring-3d      (University of Toronto, CSC417 assignment 2)
#   brown-cs-224/FEM-Stencil              (Brown University, CS2240/CS224 FEM stencil)
# The SHA-256 sums below are of the exact blobs (git blob ids in the project README).
set -euo pipefail

dest=${1:-meshes}

a3=https://raw.githubusercontent.com/dilevin/CSC417-a3-finite-elements-3d/25a62624c6bb68df1c11d2d3d1ad13fd7c173b88/data
a2=https://raw.githubusercontent.com/dilevin/CSC417-a2-mass-spring-3d/030e0666c5874a0c074f697b67048f159f6fce29/data
brown=https://raw.githubusercontent.com/brown-cs-224/FEM-Stencil/c1c20f6f2ecef2670c76a749a803111269fc0212/example-meshes

# name  source-url  sha256
files=(
  "arma_6.node        $a3/arma_6.node            eba94cb495cd76dfdeb6ec3fc62c1343d15dce9c253c6ba66e12c41d262da06d"
  "arma_6.ele         $a3/arma_6.ele             265738ac3c0d9ebe84b786072748eecfb2ca02304aa0a99221ecd7ebd6aa8746"
  "armadillo.obj      $a3/armadillo.obj          444ede88569df3c69193690de1e0e491dfe5873dd12c719f4f64569cb7243936"
  "armadillo2.obj     $a3/armadillo2.obj         c97d61c8e1c65ed6ccec7abc802e855fc635ed39600bda40e5157a5748945704"
  "coarser_bunny.mesh $a3/coarser_bunny.mesh     226942c5c20af1385e88c2fcd4b9442b26b1874411d30c63fa644df01aa4aa81"
  "coarser_bunny.obj  $a3/coarser_bunny.obj      1a5e6096cf036a7c482ab240510b8d158012ae7f07d5ac4fc0c34e4f88d4fde3"
  "coarse_bunny.mesh  $a3/coarse_bunny.mesh      47884529c5b095999a7243816788405aa213c83f78ffcaec29490b3a710ea84e"
  "coarse_bunny.obj   $a2/coarse_bunny.obj       b58cea389c105d34b1644a1da28bd3b19db62de9c1f4c350d902ffff4f53b214"
  "single-tet.mesh    $brown/single-tet.mesh     342626a3c0fad3eb487d31bd34fe72fcb57d40058bf4ece4175d7d15e723e4ec"
  "cube.mesh          $brown/cube.mesh           642caa2698d3a1a9120a1376b4736c9164b3782603e9564db0696aef2cf77c6c"
  "sphere.mesh        $brown/sphere.mesh         f5024b43b0a3cd6d44fb5757d95bffd2f849d8d1140331b52abef94fe0552414"
  "ellipsoid.mesh     $brown/ellipsoid.mesh      6d0b9ecdaa965d5751c30ef5b7acd7577ce12ee84bf4d4c76dc53a0984613b3e"
  "cone.mesh          $brown/cone.mesh           6e77d6d79246b0fc5fbfe506f3a498967d098bc4b9ce5b52bb7692010f437b2e"
)

# Fail fast and leave nothing behind: check that the host answers before anything is
# created, download into a temporary folder, and move the files into DEST only when every
# one has arrived with the right checksum.
host=https://raw.githubusercontent.com
if command -v curl >/dev/null; then
  fetch() { curl -fsS --connect-timeout 10 --max-time 120 --retry 2 -o "$2" "$1" 2>&1; }
  reach() { curl -fsS --connect-timeout 10 --max-time 20 -o /dev/null "$1" 2>&1; }
elif command -v wget >/dev/null; then
  fetch() { wget -nv --timeout=30 --tries=2 -O "$2" "$1" 2>&1 >/dev/null | tail -n 1; return "${PIPESTATUS[0]}"; }
  reach() { wget -nv --timeout=10 --tries=1 -O /dev/null "$1" 2>&1 >/dev/null | tail -n 1; return "${PIPESTATUS[0]}"; }
else
  echo "error: need curl or wget to download the meshes" >&2
  exit 1
fi

present() { [ -f "$dest/$1" ] && echo "$2  $dest/$1" | sha256sum -c --status; }
missing=0
for entry in "${files[@]}"; do
  read -r name _ sum <<<"$entry"
  present "$name" "$sum" || missing=$((missing + 1))
done
if [ "$missing" -eq 0 ]; then
  echo "all reference meshes are already in $dest (checksums match)"
  echo "now: export SOFTBENCH_DATA=\"$(cd "$dest" && pwd)\""
  exit 0
fi

read -r _ probe_url _ <<<"${files[0]}"
if ! why=$(reach "$probe_url"); then
  echo "error: cannot download from $host (offline, or blocked by a proxy?): $why" >&2
  echo "nothing was written; get the meshes on a connected machine and copy the folder, or" >&2
  echo "rerun this script when online" >&2
  exit 1
fi

tmp=$(mktemp -d "${TMPDIR:-/tmp}/softbench-meshes.XXXXXX")
trap 'rm -rf "$tmp"' EXIT

for entry in "${files[@]}"; do
  read -r name url sum <<<"$entry"
  if present "$name" "$sum"; then
    echo "ok       $name (already present)"
    continue
  fi
  if ! out=$(fetch "$url" "$tmp/$name") || [ ! -s "$tmp/$name" ]; then
    echo "error: downloading $name from $url failed: ${out:-empty file}" >&2
    echo "nothing was written to $dest" >&2
    exit 1
  fi
  if ! echo "$sum  $tmp/$name" | sha256sum -c --status; then
    echo "error: $name: SHA-256 mismatch (got $(sha256sum "$tmp/$name" | cut -d' ' -f1)," \
      "expected $sum)" >&2
    echo "nothing was written to $dest" >&2
    exit 1
  fi
  echo "ok       $name"
done

mkdir -p "$dest"
for f in "$tmp"/*; do
  [ -e "$f" ] && mv "$f" "$dest/"
done
echo
echo "all reference meshes are in $dest; now: export SOFTBENCH_DATA=\"$(cd "$dest" && pwd)\""
