#!/usr/bin/env bash
# The wheel check: build the wheel from this checkout (python -m build --wheel), install it
# in a fresh venv in a temporary folder outside the repository (dependencies from the
# package index; pip's cache makes a second check fast), and from there - no ../shared
# beside it, no source folder on sys.path, an empty mesh cache - list the packaged scenes
# and run the two scanned ones by name, so the packaged knee data must come from the wheel;
# then `fecheck validate --quick` on three rows (the rigid model, the meshes and the fits
# on the packaged knee), whose code ships in the package (fecheck.studies.thesis).
#   bash scripts/check_wheel.sh          # CI (.ci/run)
#   bash scripts/check_wheel.sh --all    # run every packaged scene and every row
# Fails (non-zero, naming the step) on any problem; removes its temporary folder.
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$PWD
py=${PYTHON:-$repo/.venv/bin/python}
tmp=$(mktemp -d "${TMPDIR:-/tmp}/fecheck-wheel.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
fail() { echo "check_wheel: FAILED: $*" >&2; exit 1; }
start=$SECONDS

rm -rf build                                   # stale modules of an earlier build
"$py" -m build --wheel --outdir "$tmp/dist" . >"$tmp/build.log" 2>&1 \
    || { tail -30 "$tmp/build.log" >&2; fail "python -m build --wheel"; }
rm -rf build                                   # build's scratch folder in the checkout
wheel=$(ls "$tmp"/dist/fecheck-*.whl)
size=$(stat -c %s "$wheel")
echo "check_wheel: built $(basename "$wheel") ($((size / 1024)) KiB)"

# The wheel holds the package (its scenes and the knee's files, as listed in SHA256SUMS)
# and nothing of the tests or validation.
"$py" - "$wheel" <<'EOF' || fail "wheel contents"
import sys, zipfile
from pathlib import Path
names = set(zipfile.ZipFile(sys.argv[1]).namelist())
data = "fecheck/data/knee/lenhart2015/"
listed = [line.split()[1] for line in Path(data, "SHA256SUMS").read_text().splitlines()]
want = {data + "SHA256SUMS", *(data + n for n in listed),
        *(f"fecheck/scenes/{p.name}" for p in Path("fecheck/scenes").glob("*.toml"))}
missing = sorted(want - names)
stray = sorted(n for n in names if n.split("/")[0] in ("tests", "validation", "scripts"))
for n in missing:
    print(f"check_wheel: not in the wheel: {n}", file=sys.stderr)
for n in stray:
    print(f"check_wheel: should not be in the wheel: {n}", file=sys.stderr)
sys.exit(1 if missing or stray else 0)
EOF

"$py" -m venv "$tmp/venv"
"$tmp/venv/bin/python" -m pip install -q "$wheel" >"$tmp/pip.log" 2>&1 \
    || { tail -30 "$tmp/pip.log" >&2; fail "pip install of the wheel"; }
echo "check_wheel: installed in a fresh venv ($((SECONDS - start)) s so far)"

cd "$tmp"
unset PYTHONPATH FECHECK_KNEE_DIR FECHECK_SHARED_DATA
export FECHECK_CACHE_DIR="$tmp/cache"
fecheck=$tmp/venv/bin/fecheck
"$tmp/venv/bin/python" -c "import fecheck, sys; sys.exit(not fecheck.__file__.startswith('$tmp/'))" \
    || fail "fecheck imported from outside the fresh venv"
"$fecheck" scenes || fail "fecheck scenes"
if [ "${1:-}" = "--all" ]; then
    scenes=$("$fecheck" scenes | awk '{print $1}')
else
    scenes="scanned-knee sphere_tibia"         # femur-tibia and sphere-tibia on the knee
fi
for scene in $scenes; do
    "$fecheck" run "$scene" --json "$tmp/$scene.json" >"$tmp/$scene.txt" 2>&1 \
        || { cat "$tmp/$scene.txt" >&2; fail "fecheck run $scene"; }
    "$tmp/venv/bin/python" -c "import json, sys; sys.exit(not json.load(open(sys.argv[1]))['converged'])" \
        "$tmp/$scene.json" || fail "fecheck run $scene did not converge"
    echo "check_wheel: fecheck run $scene: converged"
done
if [ "${1:-}" = "--all" ]; then
    rows=()
else
    rows=(--only rigid mesh fits)
fi
"$fecheck" validate --quick "${rows[@]}" --out "$tmp/validation" >"$tmp/validate.txt" 2>&1 \
    || { tail -30 "$tmp/validate.txt" >&2; fail "fecheck validate --quick ${rows[*]}"; }
grep -q '| Table 5.1 | `table_5_1` | reproduced |' "$tmp/validation/report.md" \
    || fail "fecheck validate: Table 5.1 not reproduced in $tmp/validation/report.md"
echo "check_wheel: fecheck validate --quick ${rows[*]}: report written, Table 5.1 reproduced"
echo "check_wheel: passed in $((SECONDS - start)) s"
