#!/usr/bin/env bash
# Test meshes like the users': made by a third-party mesher, never committed.
#
#   bench/meshes/make.sh [PVRSIM] [SIZES...]
#
# Into ${PVRSIM_BENCH_CACHE:-~/.cache/pvrsim-bench}/meshes it writes
#   part-<N>.vtk / part-<N>.toml  a CAD-like part (filleted block, holes, boss;
#                                 gmsh's OpenCASCADE kernel and HXT mesher, from
#                                 PyPI into a venv in the cache) meshed at about
#                                 N tetrahedra, nodes and cells in gmsh's order,
#                                 a smooth `temperature` point field, binary
#                                 legacy VTK; the scene is 512x512, orthographic,
#                                 opacity > 0 over the whole field range (every
#                                 cell visible);
#   demo.vtk / demo.toml          pvrsim's own demo vessel (2 M tets);
#   demo-perm.vtk / demo-perm.toml the same mesh, vertices and cells in a random
#                                 order (`pvrsim generate permuted`);
#   vessel-<V>.toml (and folder)  pvrsim's generated vessel at V = ${VESSEL_CELLS:-20000000}
#                                 tets, to measure against in the same run
#                                 (VESSEL_CELLS=0 skips it).
# PVRSIM: the pvrsim binary (default: `pvrsim` on PATH, else target/release/pvrsim).
# SIZES: tetrahedra counts (default 1000000 5000000 18000000). Existing files are
# kept; delete them to remake. gmsh at 18 M tets needs about 10 GB of memory
# (`free -g` first); sizes that do not fit fail with gmsh's message.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
cache="${PVRSIM_BENCH_CACHE:-$HOME/.cache/pvrsim-bench}"
pvrsim="${1:-}"
[ $# -gt 0 ] && shift
if [ -z "$pvrsim" ]; then
    pvrsim="$(command -v pvrsim || echo "$here/../../target/release/pvrsim")"
fi
[ -x "$pvrsim" ] || { echo "make.sh: no pvrsim binary at $pvrsim (build it: cargo build --release)" >&2; exit 1; }
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(1000000 5000000 18000000)
mkdir -p "$cache/meshes"
if [ ! -x "$cache/venv/bin/python" ] || ! "$cache/venv/bin/python" -c "import gmsh, numpy" 2>/dev/null; then
    echo "make.sh: installing gmsh and numpy into $cache/venv" >&2
    python3 -m venv "$cache/venv"
    "$cache/venv/bin/pip" install -q gmsh numpy
fi
out="$cache/meshes"
for n in "${sizes[@]}"; do
    case "$n" in (''|*[!0-9]*) echo "make.sh: size '$n' is not a count of tetrahedra" >&2; exit 1;; esac
    if [ -f "$out/part-$n.vtk" ] && [ -f "$out/part-$n.toml" ]; then
        echo "make.sh: keeping $out/part-$n.vtk" >&2
        continue
    fi
    echo "make.sh: meshing the part at about $n tets" >&2
    /usr/bin/time -f "make.sh: part-$n: %e s, peak %M kB" \
        "$cache/venv/bin/python" "$here/part.py" --tets "$n" --out "$out/part-$n.vtk.tmp.vtk"
    mv "$out/part-$n.vtk.tmp.vtk" "$out/part-$n.vtk"
    sed 's/part-[0-9]*\.vtk\.tmp\.vtk/part-'"$n"'.vtk/' "$out/part-$n.vtk.tmp.toml" > "$out/part-$n.toml"
    rm -f "$out/part-$n.vtk.tmp.toml"
done
if [ ! -f "$out/demo-perm.toml" ]; then
    d="$(mktemp -d)"
    "$pvrsim" demo --cells 2000000 --nodes 0 --out-dir "$d" >/dev/null
    mv "$d/demo.vtk" "$out/demo.vtk"
    mv "$d/demo.toml" "$out/demo.toml"
    rm -rf "$d"
    "$pvrsim" generate permuted --input "$out/demo.vtk" -o "$out/demo-perm.vtk"
    sed 's/"demo\.vtk"/"demo-perm.vtk"/' "$out/demo.toml" > "$out/demo-perm.toml"
fi
vessel="${VESSEL_CELLS:-20000000}"
if [ "$vessel" != 0 ] && [ ! -f "$out/vessel-$vessel/demo.toml" ]; then
    "$pvrsim" demo --cells "$vessel" --nodes 0 --out-dir "$out/vessel-$vessel" >/dev/null
fi
if [ "$vessel" != 0 ]; then
    sed 's#"demo\.vtk"#"vessel-'"$vessel"'/demo.vtk"#' "$out/vessel-$vessel/demo.toml" > "$out/vessel-$vessel.toml"
fi
ls -l "$out"
