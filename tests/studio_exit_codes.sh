#!/usr/bin/env bash
# The headless studio fails loudly and at once: exit status 1 with the reason
# for a missing scene, a scene without emitters, an export before any picture
# (--after 0) and an export into a folder that cannot be created.
#   studio_exit_codes.sh VSL_STUDIO OUT_DIR
set -uo pipefail
studio=$1 out=$2
mkdir -p "$out"
fail=0
expect_exit1() {  # name, expected text, arguments...
  local name=$1 want=$2; shift 2
  local start=$SECONDS
  timeout 120 "$studio" --headless --window 320x240 --lights 50 --width 16 "$@" >"$out/$name.log" 2>&1
  local rc=$? took=$((SECONDS - start))
  if [ $rc -ne 1 ]; then echo "$name: exit status $rc, want 1"; fail=1; fi
  if ! grep -q "$want" "$out/$name.log"; then echo "$name: no '$want' in:"; cat "$out/$name.log"; fail=1; fi
  if [ $took -gt 60 ]; then echo "$name: took $took s"; fail=1; fi
  echo "$name: exit $rc after ${took}s"
}
printf '%s' '{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],"bufferViews":[{"buffer":0,"byteLength":36}],"buffers":[{"byteLength":36,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"}]}' >"$out/dark.gltf"
: >"$out/empty.gltf"
expect_exit1 missing "cannot be read" "$out/does-not-exist.gltf" --export "$out/x"
expect_exit1 missing-no-export "cannot be read" "$out/does-not-exist.gltf"
expect_exit1 empty "error:" "$out/empty.gltf" --export "$out/x"
expect_exit1 no-emitters "no emitters" "$out/dark.gltf" --export "$out/x"
expect_exit1 after-zero "nothing to export" --export "$out/x" --after 0
touch "$out/a-file"
expect_exit1 export-unwritable "cannot create" --export "$out/a-file/sub"
exit $fail
