#!/usr/bin/env bash
# The fault matrix of the reliability issue, driven through the installed `envfit` CLI in a
# scratch folder: one row per fault, "label | rc=N | the first error line on stderr".
# Usage: bash bench/fault_matrix.sh MAP.exr
F=$(realpath "${1:?usage: bash bench/fault_matrix.sh MAP.exr (any real lat-long map)}")
work=$(mktemp -d); cd "$work"
mkdir -p w; cd w
touch afile; mkdir adir; ln -s loop loop
envfit synth tiny84.exr --kind gp --height 4 --seed 0 >/dev/null 2>&1 || true
python - <<'PY'
import numpy as np, OpenImageIO as oiio
from envfit.maps.envmap import EnvMap
from envfit.maps.io import save_envmap
save_envmap("zero.exr", EnvMap(np.zeros((16, 32, 3), np.float32)))
save_envmap("tiny21.exr", EnvMap(np.ones((1, 2, 3), np.float32)))
save_envmap("tiny84.exr", EnvMap(np.random.default_rng(0).random((4, 8, 3)).astype(np.float32)))
img = (np.random.default_rng(0).random((16, 32, 3)) * 255).astype(np.uint8)
out = oiio.ImageOutput.create("m8.png"); out.open("m8.png", oiio.ImageSpec(32, 16, 3, "uint8")); out.write_image(img); out.close()
PY
run() { local label="$1"; shift; local err; err=$( { timeout 120 "$@" >/dev/null; echo "rc=$?" >&2; } 2>&1 ); local rc=$(echo "$err" | grep -o 'rc=[0-9]*' | tail -1); local first=$( (echo "$err" | grep -m1 "error:") || (echo "$err" | grep -v "^rc=" | grep -v "%|" | grep -v "^\s*$" | head -1) ); printf '%s | %s | %s\n' "$label" "$rc" "$first"; }
run "table2 forest --s 1.5 --n 1e9" envfit table2 $F --s 1.5 --n 1000000000
run "table2 --out under a file" envfit table2 --quick --out afile/sub
run "fit --out under a file" envfit fit --max-height 16 --n 100 --out afile/sub
run "validate --out under a file" envfit validate --quick --out afile/sub
run "advise --out under a file" envfit advise --brdf diffuse --target-rmse 0.01 --out afile/sub
run "synth into a file's child" envfit synth afile/m.exr --kind gp --height 8
run "info --json under a file" envfit info tiny84.exr --json afile/x.json
run "theory figures --out under a file" envfit theory figures --out afile/sub
run "--json naming a folder" envfit table2 --quick --json adir
run "--out symlink loop" envfit theory wce --brdf diffuse --pointset sf --n 64 --out loop
run "--n 100.5" envfit table2 --quick --n 100.5
run "--s empty" envfit table2 --quick --s ""
run "--s 1.5,1.5" envfit table2 --quick --s 1.5,1.5
run "--n 100,100" envfit table2 --quick --n 100,100
run "all-zero map, fit --scale linear" envfit fit zero.exr --scale linear --n 100
run "all-zero map, fit --scale log" envfit fit zero.exr --scale log --n 100
run "8x4 map --n 5000" envfit table2 tiny84.exr --n 5000
run "2x1 map --n 5000" envfit table2 tiny21.exr --n 5000
run "8-bit PNG (note, on stdout)" envfit info m8.png
envfit info m8.png 2>/dev/null | grep -m1 "note" | sed 's/^/   stdout: /'
envfit table2 tiny84.exr --s 1.5 --n 20 --out st -q >/dev/null 2>&1
python - <<'PY'
import json, pathlib
p = next(pathlib.Path("st/cells").glob("*.json")); d = json.loads(p.read_text()); d["cell"]["rmse"] = 0.0; p.write_text(json.dumps(d))
PY
echo "edited cell rerun: $(envfit table2 tiny84.exr --s 1.5 --n 20 --out st -q 2>&1 >/dev/null | head -1)"
head -c 300 /dev/urandom > "$(ls st/cells/*.json | head -1)"
echo "random-bytes cell rerun: $(envfit table2 tiny84.exr --s 1.5 --n 20 --out st -q 2>&1 >/dev/null | head -1)"
