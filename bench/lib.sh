# Shell helpers shared by the benchmark scripts (bench/compare.sh, bench/area-plane.sh,
# bench/sun-pool.sh, bench/run.sh, bench/versus.sh, bench/gamma_sweep.sh,
# bench/povray-glass.sh, bench/transport.sh, bench/precompute-ab.sh).
# The caller sets $root (the repository), $work (a scratch folder), $scale and $tool (its
# name, for messages).

# The machine, for the results' headers: CPU model and core count.
machine="$(grep -m1 'model name' /proc/cpuinfo | sed 's/.*: //'), $(nproc) cores"

# n K: the budget K times the scale, at least 1, rounded.
n() { awk -v a="$1" -v k="$scale" 'BEGIN { v = a * k; if (v < 1) v = 1; printf "%d", v + 0.5 }'; }

# cpu LOG CMD...: runs CMD (output to LOG), prints its CPU-seconds (user + sys).
cpu() {
  log=$1
  shift
  if ! /usr/bin/time -f '%U %S' -o "$work/time" "$@" > "$log" 2>&1; then
    echo "$tool: failed: $*" >&2
    tail -5 "$log" >&2
    exit 1
  fi
  awk '{ printf "%.3f", $1 + $2 }' "$work/time"
}

# interpolate FILE X: log-log interpolation of the curve "x y" (sorted by x) at X; beyond
# its ends, extrapolated along 1/x (the rate of unbiased Monte Carlo).
interpolate() {
  sort -g "$1" | awk -v X="$2" '
    { x[NR] = log($1); y[NR] = log($2) }
    END {
      lx = log(X)
      if (lx <= x[1]) { printf "%.4g", exp(y[1] - (lx - x[1])); exit }
      if (lx >= x[NR]) { printf "%.4g", exp(y[NR] - (lx - x[NR])); exit }
      for (i = 1; i < NR; i++)
        if (lx <= x[i + 1]) {
          t = x[i + 1] > x[i] ? (lx - x[i]) / (x[i + 1] - x[i]) : 0
          printf "%.4g", exp(y[i] + t * (y[i + 1] - y[i])); exit
        }
    }'
}

# slope FILE: the least-squares slope of log y against log x of the curve "x y" (-1 for
# unbiased Monte Carlo with independent samples; a floor or a bias flattens it).
slope() {
  awk '{ x = log($1); y = log($2); n++; sx += x; sy += y; sxx += x * x; sxy += x * y }
    END { d = n * sxx - sx * sx; if (n > 1 && d > 0) printf "%.2f", (n * sxy - sx * sy) / d; else printf "?" }' "$1"
}

# build_release ROOT: configures ROOT/build as a Release build when it has no cache yet,
# then builds it (quietly); the benchmarks use the binaries there.
build_release() {
  if [ ! -f "$1/build/CMakeCache.txt" ]; then
    cmake -S "$1" -B "$1/build" -DCMAKE_BUILD_TYPE=Release > /dev/null
  fi
  cmake --build "$1/build" -j "$(nproc)" > /dev/null
}

# picked SCENE: whether BBC_BENCH_SCENES (names separated by spaces; default all) names SCENE.
picked() { case " ${BBC_BENCH_SCENES:-$1} " in *" $1 "*) return 0 ;; esac; return 1; }

# shared_scenes DIR [FILE...]: prints the folder of the shared research scenes (plane1k,
# pool4k, ball320...: glTF files kept outside the repository, on some machines only): DIR
# when not empty (a script's own argument wins), else $BBC_SHARED_DIR/scenes
# (BBC_SHARED_DIR: the folder holding scenes/), else ../shared/scenes beside the
# repository. When that folder or one of the FILEs in it is missing, prints nothing, says
# in one line on stderr what is missing and how to provide it, and returns 1; the caller
# then skips what needs the scenes and exits 0:
#   scenes=$(shared_scenes "$dir" pool4k.gltf) || exit 0
shared_scenes() {
  if [ -n "$1" ]; then
    shared_dir=$1
    shared_how="as given on the command line"
  else
    shared_dir=${BBC_SHARED_DIR:-$(cd "$root/.." && pwd)/shared}/scenes
    shared_how="set BBC_SHARED_DIR to the folder holding scenes/"
  fi
  shift
  if [ ! -d "$shared_dir" ]; then
    echo "$tool: skipped: no shared scenes at $shared_dir ($shared_how)" >&2
    return 1
  fi
  shared_dir=$(cd "$shared_dir" && pwd)
  shared_missing=
  for shared_file in "$@"; do
    [ -f "$shared_dir/$shared_file" ] || shared_missing="$shared_missing${shared_missing:+, }$shared_file"
  done
  if [ -n "$shared_missing" ]; then
    echo "$tool: skipped: no $shared_missing in $shared_dir ($shared_how)" >&2
    return 1
  fi
  echo "$shared_dir"
}

# povray_run POV: renders POV with POV-Ray at $width x $height, $threads threads (3x3
# supersampling of every pixel, as bench/compare.sh) to OUT.exr beside it and prints its
# CPU-seconds; cached in $work/pov by the content of POV. POV-Ray writes below the
# current folder only: run it from the repository.
povray_run() {
  key=$work/pov/$( (cat "$1"; echo "+W$width +H$height +WT$threads") | md5sum | cut -c1-16)
  if [ ! -f "$key.cpu" ]; then
    cpu "$key.log" povray "+I$1" "+O$key.exr" +FE +W$width +H$height -D +WT$threads -V \
      +A0.0 +AM1 +R3 > "$key.tmp"
    mv "$key.tmp" "$key.cpu"
  fi
  cp "$key.exr" "${1%.pov}.exr"
  cp "$key.log" "${1%.pov}.log"
  cat "$key.cpu"
}
