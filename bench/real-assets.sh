#!/bin/sh
# bbc on public sample assets, as a user would try them: the Khronos glTF sample assets
# TransmissionTest and GlassVaseFlowers in the shared scenes' real/ folder, lit as
# real/README.md says they were when first tried. bench/real-assets-scenes.py writes a
# new .gltf per asset into bench/work/real-assets/ that references the original .bin
# files and images by relative URI (nothing is copied or changed) and adds a point light
# as Blender's exporter writes a lamp of P watts (P / (4 pi) * 683 cd, photometric): 100 W
# at (0.4, 0.9, 1.0) for TransmissionTest; for GlassVaseFlowers 20 W at (-0.13, 0.45,
# 0.15) over a 1.2 m square floor of albedo 0.8 at y = 0 centred under it, and a camera
# looking down at the vase with KHR_materials_volume.
#
#   sh bench/real-assets.sh [--runs "R T TT all"] [--probe-runs "TT"] [--memory-gb G]
#                           [--timeout S] [--spp N] [--reference PHOTONS] [--ref-spp N]
#                           [--dry-run] [SHARED_SCENES_DIR]
#
# SHARED_SCENES_DIR is the folder holding real/; by default $BBC_SHARED_DIR/scenes
# (BBC_SHARED_DIR: the folder holding scenes/), else ../shared/scenes beside the
# repository. Without it the script says so in one line and exits 0.
#
# Each asset is precomputed once per entry of --runs: a chain type (bbc-precompute
# --chains R, T, TT, ...) or "all", the defaults (every chain type the materials form,
# less the two-bounce types over --double-budget), one at a time, with
# --threads 2, under `ulimit -v` of --memory-gb (default 8) and stopped after --timeout
# seconds (default 600; then SIGKILL 30 s later if it has not stopped). The status says
# what the user saw: ok; "refused: estimate ..." when bbc-precompute's estimate (printed
# before any bounding) did not fit its memory budget; "out of memory (G GB) while ..."
# with the phase it named; a timeout; or another failure with its last message. A run
# that does not finish is reported with what it had used and how far it got (its progress
# bars, forced on into its log: light-triangle prefixes searched while finding the
# candidates, then candidate tuples bounded of all), and each run's estimate line is
# quoted in the notes. With --dry-run each precompute only counts the candidates and
# prints its estimate (bbc-precompute --dry-run: nothing written, nothing rendered); the
# table then shows the estimate (candidates, cache size) and the results go to
# bench/results/real-assets-dry-run.md instead. A probe,
# GlassVaseFlowers-floor, is the vase scene with the floor as its only receiver (the
# flowers and the alpha-blended vase get role none), run for --probe-runs (default TT):
# what the curved receivers cost. Each cache that is
# written is rendered at 320x240 with --spp (default 4), --threads 2, under the same
# limits, with a PNG preview beside it in bench/work/real-assets/. CPU-s are user + sys
# of the whole process (/usr/bin/time). With --reference PHOTONS (default 0: none), each
# run whose cache was written is also compared with an
# independent light-traced reference where the caustic is seen directly: `bench/light_trace
# SCENE --chains LIST --width 320 --photons PHOTONS --seed 1 --punctual-only` (the lamp
# alone: the caches hold no emissive triangle's tuples) against `bbc-render --only
# seen-caustics --chains LIST --max-depth 2 + its longest chain --spp --ref-spp (default
# 64)`; for "all", `--any-chain 2` (every path of one or two specular vertices, glass
# reflecting with Fresnel's probability too) against `bbc-render --only seen-caustics
# --max-depth 4` (the cache's chain types, and light tracing for what it lacks; only where
# the camera sees the caustic directly, as a light tracer sees it),
# by bench/image_error with eps = (the reference's lit mean / 10)^2 (the relMSE of
# bench/compare.sh, whose caustics are of order 1, scaled to the scene's radiance), and
# the ratio of the images' means; a second reference of PHOTONS / 4 photons (seed 2)
# against the first gives the reference's own noise (about 5 times the first's alone).
# Writes bench/results/real-assets.md.
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
runs="R T TT all"
probe_runs="TT"
memory_gb=8
timeout=600
spp=4
photons=0
ref_spp=64
dry_run=0
scenes=""
usage="usage: sh bench/real-assets.sh [--runs \"R T TT all\"] [--probe-runs \"TT\"] [--memory-gb G] [--timeout S] [--spp N] [--reference PHOTONS] [--ref-spp N] [--dry-run] [SHARED_SCENES_DIR]"
while [ $# -gt 0 ]; do
  case $1 in
    --runs) runs=$2; shift 2 ;;
    --probe-runs) probe_runs=$2; shift 2 ;;
    --memory-gb) memory_gb=$2; shift 2 ;;
    --timeout) timeout=$2; shift 2 ;;
    --spp) spp=$2; shift 2 ;;
    --reference) photons=$(awk -v p="$2" 'BEGIN { printf "%.0f", p }'); shift 2 ;;
    --ref-spp) ref_spp=$2; shift 2 ;;
    --dry-run) dry_run=1; shift ;;
    -h|--help) sed -n '2,/^set -eu/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "$usage" >&2; exit 2 ;;
    *) scenes=$1; shift ;;
  esac
done
if [ "$memory_gb" -gt 8 ]; then
  echo "real-assets.sh: --memory-gb $memory_gb: at most 8 on a shared machine" >&2
  exit 2
fi
tool=real-assets.sh
scale=1
work=$root/bench/work/real-assets
out=$root/bench/results
. "$root/bench/lib.sh"
scenes=$(shared_scenes "$scenes" real/README.md real/TransmissionTest/TransmissionTest.gltf \
  real/GlassVaseFlowers/GlassVaseFlowers.gltf) || exit 0
command -v /usr/bin/time > /dev/null || { echo "$tool: /usr/bin/time is missing" >&2; exit 1; }
build_release "$root"
pre=$root/build/bbc-precompute/bbc-precompute
ren=$root/build/bbc-render/bbc-render
lt=$root/build/bench/light_trace
err=$root/build/bench/image_error
mkdir -p "$work" "$out"
commit=$(git -C "$root" rev-parse --short HEAD 2> /dev/null || echo unknown)
changed=$(git -C "$root" status --porcelain --untracked-files=no -- . ':(exclude)bench' 2> /dev/null |
  wc -l)
[ "$changed" -eq 0 ] || commit="$commit (uncommitted changes in $changed files outside bench/)"
load_start=$(cut -d' ' -f1-3 /proc/loadavg)
python3 "$root/bench/real-assets-scenes.py" "$scenes/real" "$work" > /dev/null
assets="TransmissionTest GlassVaseFlowers GlassVaseFlowers-floor"
# runs_of ASSET: the runs of that asset.
runs_of() { if [ "$1" = GlassVaseFlowers-floor ]; then echo "$probe_runs"; else echo "$runs"; fi; }
limit_kb=$((memory_gb * 1024 * 1024))
# --dry-run: the estimates only, in a results file of their own.
what="" suffix="" results=$out/real-assets.md
if [ "$dry_run" = 1 ]; then
  what=" --dry-run" suffix=-dry-run results=$out/real-assets-dry-run.md
fi

# field JSON KEY: a number of a --json statistics file.
# (the first occurrence: the statistics come before the estimate's copy of some keys)
field() { sed -n "s/^ *\"$2\": \([0-9.e+-]*\),\{0,1\}$/\1/p" "$1" | head -1; }

# lines LOG: the log as lines (progress bars redrawn with CR split, erasures removed).
lines() { tr '\r' '\n' < "$1" | sed 's/\x1b\[K//g'; }

# estimate LOG: bbc-precompute's estimate line without its tool name, empty if none.
estimate() { lines "$1" | sed -n 's/^bbc-precompute: estimate: //p' | head -1; }

# refusal LOG: "refused: estimate N candidate tuples, about X needed, over the budget of B"
# when the estimate did not fit the budget, else empty.
refusal() {
  lines "$1" | sed -n 's/.*: \([0-9.e]*\) candidate tuples (.*the precompute needs about \([^(]*[^ (]\) (.*over the budget of \([^;]*\);.*/refused: estimate \1 candidate tuples, about \2 needed, over the budget of \3/p' |
    head -1
}

# limited TIMEFILE LOG CMD...: runs CMD under `ulimit -v` and the timeout, stdout and
# stderr to LOG, "user sys wall maxrss-KB" to TIMEFILE; prints its status: ok,
# "refused: estimate ...", "timeout S s", "out of memory (G GB) while PHASE" or
# "failed (...)".
limited() {
  tf=$1
  lg=$2
  shift 2
  if (ulimit -v "$limit_kb" &&
    exec /usr/bin/time -f '%U %S %e %M' -o "$tf" timeout -k 30 "$timeout" "$@") > "$lg" 2>&1; then
    echo ok
  elif grep -Eq "Command exited with non-zero status (124|137)|Command terminated by signal (9|15)" \
    "$tf"; then
    echo "timeout ${timeout} s"
  elif [ -n "$(refusal "$lg")" ]; then
    refusal "$lg"
  elif grep -qi "out of memory\|bad_alloc\|cannot allocate" "$lg"; then
    phase=$(lines "$lg" | sed -n 's/.*out of memory within the budget of .*) \(while [^;]*\);.*/ \1/p' |
      head -1)
    echo "out of memory (${memory_gb} GB)$phase"
  elif grep -q "the cache would hold no tuple" "$lg"; then
    echo "no tuple: $(sed -n 's/.*the cache would hold no tuple: \([^;]*\);.*/\1/p' "$lg" | head -1)"
  else
    code=$(sed -n 's/^Command \(exited with non-zero status\|terminated by signal\) /\1 /p' "$tf" |
      head -1)
    echo "failed (${code:-unknown}: $(lines "$lg" | grep -v '^bounding \[\|^finding tuples \[' |
      grep -v warning | grep -v '^ *$' | tail -1 | cut -c1-120))"
  fi
}

# times TIMEFILE: "CPU-s wall-s RSS-MB" of a limited run.
times_of() {
  grep -v '^Command' "$1" | tail -1 |
    awk '{ printf "%.2f %.1f %.0f", $1 + $2, $3, $4 / 1024 }'
}

# progress LOG: the last state of the bounding bar ("42%, 1234/5678 candidate tuples
# bounded after 01:20"), empty if bounding had not begun.
progress() {
  lines "$1" | grep '^bounding \[' | tail -1 |
    sed -n 's/^bounding \[[#.]*\] *\([0-9]*%\) *\([^ ]*\) elapsed.*  \([0-9]*\/[0-9]*\) tuples.*/\1, \3 candidate tuples bounded after \2/p'
}

# finding LOG: the last state of the bar of the candidate search ("80%, 11232/14038
# light-triangle prefixes searched after 04:13"), empty if it had not begun.
finding() {
  lines "$1" | grep '^finding tuples \[' | tail -1 |
    sed -n 's/^finding tuples \[[#.]*\] *\([0-9]*%\) *\([^ ]*\) elapsed.*  \([0-9]*\/[0-9]*\) light-triangle prefixes.*/\1, \3 light-triangle prefixes searched after \2/p'
}

# compare_reference SCENE NAME CHAINS: the caustic of NAME's cache against light-traced
# references (--reference); prints "relMSE R, mean ratio A (lit-mean Q); reference ...".
compare_reference() {
  sc=$1 nm=$2 ch=$3
  case ,$ch, in *,[RT][RT],*) depth=4 ;; *) depth=3 ;; esac
  # The defaults: every path of one or two specular vertices, glass reflecting too, in
  # the reference; the render's cache and light tracing (for what the cache lacks).
  lt_pick="--chains $ch" render_pick="--chains $ch"
  [ "$ch" != all ] || { depth=4 lt_pick="--chains R --any-chain 2" render_pick=""; }
  r1=$work/$nm-ref-$photons-1.exr r2=$work/$nm-ref-$photons-2.exr
  echo "$tool: $nm: light-traced references, $photons and $((photons / 4)) photons" >&2
  for k in 1 2; do
    f=$r1 n=$photons
    [ "$k" = 1 ] || f=$r2 n=$((photons / 4))
    # A reference is reused while it is newer than bench/light_trace.
    # shellcheck disable=SC2086 # split into options on purpose
    [ "$f" -nt "$lt" ] || limited "$work/$nm.ref$k.time" "$work/$nm.ref$k.log" "$lt" "$sc" $lt_pick \
      --width 320 --photons "$n" --seed "$k" --threads 2 --punctual-only -o "$f" > /dev/null
  done
  [ -f "$r1" ] && [ -f "$r2" ] || { echo "reference failed"; return; }
  ref_cpu=$(times_of "$work/$nm.ref1.time" | cut -d' ' -f1)
  echo "$tool: $nm: caustic render, $ref_spp spp" >&2
  cstatus=$(limited "$work/$nm.caustic.time" "$work/$nm.caustic.log" "$ren" "$sc" \
    --cache "$work/$nm.bbc" -o "$work/$nm-caustic.exr" --only seen-caustics $render_pick \
    --max-depth "$depth" --width 320 --spp "$ref_spp" --threads 2 --no-progress)
  [ "$cstatus" = ok ] || { echo "caustic render: $cstatus"; return; }
  eps=$("$err" "$r1" "$r1" | awk '{ printf "%.6g", ($6 / 10) ^ 2 }')
  if [ "$(awk -v e="$eps" 'BEGIN { print (e > 0) }')" = 0 ]; then
    echo "the reference is black: no caustic of these chains is seen directly"
    return
  fi
  # shellcheck disable=SC2046 # split into fields on purpose
  set -- $("$err" "$work/$nm-caustic.exr" "$r1" --eps "$eps")
  mine="relMSE $2, mean ratio $8 (lit-mean $4)"
  # shellcheck disable=SC2046
  set -- $("$err" "$r2" "$r1" --eps "$eps")
  echo "$mine; $(times_of "$work/$nm.caustic.time" | cut -d' ' -f1) CPU-s at $ref_spp spp;" \
    "reference $photons photons, $ref_cpu CPU-s (the second against it: relMSE $2, mean ratio $8)"
}

rows=$work/rows
notes=$work/notes
: > "$rows"
: > "$notes"
for asset in $assets; do
  scene=$work/$asset-lit.gltf
  for run in $(runs_of "$asset"); do
    name=$asset-$run
    if [ "$run" = all ]; then chains=""; label="all (default)"; else chains="--chains $run"; label=$run; fi
    echo "$tool: $asset, $label: precompute$what (at most ${timeout} s, ${memory_gb} GB)" >&2
    if [ "$dry_run" = 1 ]; then
      name=$name-dry-run
      rm -f "$work/$name.log"
      # shellcheck disable=SC2086
      status=$(limited "$work/$name.time" "$work/$name.log" "$pre" "$scene" --dry-run \
        --threads 2 --progress $chains)
    else
      rm -f "$work/$name.bbc" "$work/$name.json" "$work/$name.exr" "$work/$name.png"
      # shellcheck disable=SC2086
      status=$(limited "$work/$name.time" "$work/$name.log" "$pre" "$scene" -o "$work/$name.bbc" \
        --threads 2 --progress --json "$work/$name.json" $chains)
    fi
    # shellcheck disable=SC2046 # split into fields on purpose
    set -- $(times_of "$work/$name.time")
    cpu=$1 wall=$2 rss=$3
    candidates=- tuples=- mb=- render=- note= reference=-
    e=$(estimate "$work/$name.log")
    if [ "$dry_run" = 1 ] && [ "$status" = ok ] && [ -n "$e" ]; then
      status="estimate"
      candidates=$(echo "$e" | cut -d' ' -f1)
      mb="~$(echo "$e" | sed -n 's/.*cache [a-z ]*about \([0-9.]* [kMG]B\).*/\1/p;s/.*cache at least \([0-9.]* [kMG]B\).*/>= \1/p')"
      note="estimate: $e"
    elif [ "$status" = ok ] && [ -f "$work/$name.json" ]; then
      j=$work/$name.json
      candidates=$(field "$j" candidate_tuples)
      tuples=$(field "$j" tuples)
      mb=$(awk -v b="$(field "$j" file_bytes)" 'BEGIN { printf "%.1f", b / 1048576 }')
      per=""
      for c in R T RR RT TR TT; do
        n=$(field "$j" "tuples_$c")
        [ "${n:-0}" = 0 ] || per="$per${per:+, }$c $n"
      done
      note=$(awk -v t="$(field "$j" tuple_seconds)" -v b="$(field "$j" bounding_seconds)" \
        -v w="$(field "$j" writing_seconds)" -v p="$(field "$j" position_pieces_per_tuple)" \
        -v i="$(field "$j" irradiance_pieces_per_tuple)" -v e="$(field "$j" entries)" \
        -v s="$(field "$j" spill_bytes)" -v per="$per" \
        'BEGIN { printf "stored %s; wall: finding candidates %.1f s, bounding %.1f s, writing %.1f s; pieces per tuple %.1f position, %.1f irradiance; %d grid entries (%.0f MB spilled)",
                 per == "" ? "none" : per, t, b, w, p, i, e, s / 1e6 }')
      [ -z "$e" ] || note="$note; estimate: $e"
      # A short render with the cache.
      echo "$tool: $asset, $label: render 320x240, $spp spp" >&2
      rstatus=$(limited "$work/$name.render.time" "$work/$name.render.log" "$ren" "$scene" \
        --cache "$work/$name.bbc" -o "$work/$name.exr" --png "$work/$name.png" --width 320 \
        --height 240 --spp "$spp" --threads 2 --no-progress --stats)
      # shellcheck disable=SC2046 # split into fields on purpose
      set -- $(times_of "$work/$name.render.time")
      if [ "$rstatus" = ok ]; then
        render="$1 CPU-s, $2 s wall ($(sed -n 's/^time *//p' "$work/$name.render.log" | head -1) rendering)"
        s=$(sed -n 's/^caustics *//p' "$work/$name.render.log" | head -1)
        [ -z "$s" ] || note="$note; render: $s"
        case $s in
          *" 0.000 solutions per sampled tuple"*) note="$note: no sampled tuple had a path" ;;
        esac
      else
        render="$rstatus"
      fi
      [ "$photons" = 0 ] || reference=$(compare_reference "$scene" "$name" "$run")
    else
      p=$(progress "$work/$name.log")
      f=$(finding "$work/$name.log")
      if [ "${status#no tuple}" != "$status" ]; then
        note="refused before bounding"
      elif [ "${status#refused}" != "$status" ]; then
        note="refused before bounding, after counting the candidates"
        candidates=$(echo "$status" | sed -n 's/^refused: estimate \([0-9.e]*\) .*/\1/p')
      elif [ -n "$p" ]; then
        note="bounding: $p"
        candidates=$(echo "$p" | sed -n 's/.*[0-9]*\/\([0-9]*\) candidate.*/\1/p')
      elif [ -n "$f" ]; then
        note="finding the candidates: $f"
      else
        note="no progress bar: it stopped before the candidate search began"
      fi
      [ -z "$e" ] || note="$note; estimate: $e"
      m=$(lines "$work/$name.log" | grep -v '^bounding \[\|^finding tuples \[' |
        grep -v 'warning\|^bbc-precompute: estimate: ' | grep -v '^ *$' | tail -2 | tr '\n' ' ' |
        cut -c1-300)
      [ -z "$m" ] || note="$note; last messages: $m"
    fi
    echo "$asset|$label|$status|$cpu|$wall|$rss|$candidates|$tuples|$mb|$render|$reference" >> "$rows"
    echo "- $asset, $label: $status; $note" >> "$notes"
  done
done

# The loader's warnings, once per asset (every run of an asset loads the same scene).
warnings=$work/warnings
: > "$warnings"
for asset in $assets; do
  # shellcheck disable=SC2046 # split into fields on purpose
  set -- $(runs_of "$asset")
  [ $# -gt 0 ] || continue
  tr '\r' '\n' < "$work/$asset-$1$suffix.log" | grep 'warning' | sed "s|$work/||" |
    sort -u >> "$warnings" || true
done

# Notes written by hand below the marker line of the results file are kept.
hand=$work/hand-notes
: > "$hand"
if [ -f "$results" ]; then
  sed -n '/^<!-- by hand/,$p' "$results" > "$hand"
fi
{
  echo "# bbc on public sample assets"
  echo
  echo "\`sh bench/real-assets.sh --runs \"$runs\" --probe-runs \"$probe_runs\" --memory-gb $memory_gb --timeout $timeout --spp $spp --reference $photons --ref-spp $ref_spp$what\`"
  echo "at $commit; $machine (load average $load_start at the start, $(cut -d' ' -f1-3 /proc/loadavg) at the end)."
  echo "The Khronos sample assets in \`$scenes/real\` (unchanged; see its README.md), lit as"
  echo "that README says by \`bench/real-assets-scenes.py\` (new .gltf files in bench/work/real-assets/"
  echo "referencing the originals): TransmissionTest under a 100 W point lamp at (0.4, 0.9, 1.0);"
  echo "GlassVaseFlowers under a 20 W lamp at (-0.13, 0.45, 0.15) over a 1.2 m floor of albedo 0.8,"
  echo "with a camera looking down at the KHR_materials_volume vase; GlassVaseFlowers-floor is that scene"
  echo "with the floor as its only receiver (flowers and alpha vase role none). Lamps as Blender's exporter writes"
  echo "them (P / (4 pi) * 683 cd, photometric). Each precompute: \`bbc-precompute SCENE -o C.bbc"
  echo "--threads 2 [--chains X]\`, one at a time, under \`ulimit -v\` of $memory_gb GB and a ${timeout} s"
  echo "timeout; each cache written is rendered at 320x240, $spp spp, 2 threads (\`bbc-render --cache"
  echo "--stats\`, PNG previews in bench/work/real-assets/). CPU-s are user + sys of the whole process,"
  echo "peak RSS from /usr/bin/time; candidates of an unfinished run are the progress bar's total"
  echo "or the refusal's count."
  if [ "$dry_run" = 1 ]; then
    echo "With --dry-run each precompute only counted the candidates, bounded a sample and printed"
    echo "its estimate (\`bbc-precompute --dry-run\`): nothing was written or rendered; status"
    echo "\"estimate\" is such a run that finished, and the cache MB are the estimate's."
  fi
  echo
  echo "| asset | chains | status | CPU-s | wall s | peak RSS MB | candidate tuples | stored tuples | cache MB | render | caustic vs light-traced reference |"
  echo "|---|---|---|---:|---:|---:|---:|---:|---:|---|---|"
  awk -F'|' '{ printf "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n", $1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11 }' "$rows"
  echo
  echo "Per run (from each precompute's --json statistics, or, for a run that did not finish,"
  echo "its progress bar and last messages):"
  echo
  cat "$notes"
  echo
  echo "What the loader said about the scenes (every run prints the same):"
  echo
  echo '```'
  cat "$warnings"
  echo '```'
  if [ -s "$hand" ]; then
    echo
    cat "$hand"
  fi
} > "$results"
cat "$results"
