#!/usr/bin/env bash
# Issue 10's interactivity figures, measured by the studio itself (its log's
# "first picture ... ms after the settings changed", from a control's last
# change, the settle delay included, to the first snapshot of the new
# settings reaching the UI thread). Needs Xvfb, openbox, xdotool, ImageMagick
# (`bash scripts/setup.sh --measure` installs them).
#   xvfb-run -a -s "-screen 0 1600x1000x24" bash scripts/measure-studio-latency.sh [OUT] [change|drag|mrcs]
# change: cornell-glossy at 256 px; clicks the seed "+" button six times, 2 s
#         apart (the button sits at (220, 549) in the 1600x1000 window's default layout;
#         a click restarts at once, only a drag waits for a pause).
# drag:   the same, dragging the radius-scale slider six times (a press, which
#         moves the value to the pointer, a quick drag, a 1 s rest, the release).
# mrcs:   cornell-glossy at 512x512, 100,000 lights, MRCS 300 rows / 900
#         clusters, the studio's default 8 light sets (LIGHT_SETS=1 for one):
#         the time to the first picture (the first set's complete VSL image,
#         100,000 VSLs; VPL's columns follow), the session's stage timings,
#         the studio's CPU seconds then and the load average. Each MRCS set
#         renders its share of the 64 direct-light samples per pixel (8 of 8).
# STUDIO_ARGS: more options for the studio (change and drag), e.g.
#   STUDIO_ARGS='--lobe-gather 100000' (its controls push the seed button to
#   (221, 688): SEED_BUTTON='221 688').
# Run on an idle machine; prints the log lines and saves a screenshot (mrcs:
# also one at the first picture, mrcs-first.png).
set -uo pipefail
cd "$(dirname "$0")/.." || exit 1
out=${1:-out/latency}
mode=${2:-change}
studio=${STUDIO:-build/bin/vsl-studio}
mkdir -p "$out"
export XDG_CONFIG_HOME="$out/config"
openbox >/dev/null 2>&1 &
sleep 1
if [ "$mode" = mrcs ]; then
  "$studio" --fresh --window 1600x1000 --verbose assets/scenes/cornell-glossy.gltf --width 512 --lights 100000 \
    --mrcs 300,900 --light-sets "${LIGHT_SETS:-8}" >"$out/studio.log" 2>&1 &
  pid=$!
  for _ in $(seq 1 1500); do sleep 0.2; grep -q "first picture" "$out/studio.log" && break; done
  # utime + stime of every thread (exited ones included), in clock ticks.
  cpu=$(awk '{ print $14 + $15 }' /proc/$pid/stat 2>/dev/null)
  echo "studio CPU at the first picture: $(awk -v t="${cpu:-0}" -v hz="$(getconf CLK_TCK)" 'BEGIN { printf "%.1f", t / hz }') s; load average $(cut -d' ' -f1-3 /proc/loadavg)"
  sleep 2  # the frame that shows it (the log line is written when the UI pulls the snapshot)
  import -window root "$out/$mode-first.png"
  # Then the light set's end (VPL's columns), if this studio logs its stages.
  for _ in $(seq 1 300); do
    grep -q "light set 1: MRCS [0-9]" "$out/studio.log" || ! grep -q "light set 1:" "$out/studio.log" && break
    sleep 1
  done
  sleep 1
else
  # shellcheck disable=SC2086 # STUDIO_ARGS is a list of options
  "$studio" --fresh --window 1600x1000 --verbose assets/scenes/cornell-glossy.gltf --width 256 ${STUDIO_ARGS:-} \
    >"$out/studio.log" 2>&1 &
  pid=$!
  sleep 10
  for i in 1 2 3 4 5 6; do
    if [ "$mode" = drag ]; then
      # Drag the radius-scale slider (its bar spans x 18-230 at y 180) and
      # rest; pressing it already moves the value to the pointer (one
      # restart), the drag's pause restarts again.
      if [ $((i % 2)) = 1 ]; then a=130 b=160; else a=160 b=130; fi
      xdotool mousemove $a 180 mousedown 1
      sleep 0.1
      for x in $(seq $a $(((b - a) / 10)) $b); do xdotool mousemove "$x" 180; done
      sleep 1
      xdotool mouseup 1
    else
      # shellcheck disable=SC2086 # two coordinates
      xdotool mousemove ${SEED_BUTTON:-220 549} click 1
    fi
    sleep 2
  done
fi
import -window root "$out/$mode.png"
wid=$(xdotool search --name '^vsl-studio$' | head -1)
[ -n "$wid" ] && xdotool key --window "$wid" ctrl+q
for _ in $(seq 1 50); do kill -0 $pid 2>/dev/null || break; sleep 0.1; done
kill $pid 2>/dev/null
grep -i "first picture\|light set [0-9]*:\|reference: first pass" "$out/studio.log"
# change: the changes' values (generation 1 is the launch), their median and
# how many are within 250 and 200 ms.
if [ "$mode" != mrcs ]; then
  grep -o "generation [0-9]*: first picture [0-9]* ms" "$out/studio.log" | awk '$2 != "1:" { print $5 }' | sort -n |
    awk '{ v[NR] = $1; if ($1 <= 250) a++; if ($1 <= 200) b++ }
         END { if (NR) printf "changes: %d, median %s ms, %d within 250 ms, %d within 200 ms\n", NR,
                 (NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2), a, b }'
fi
