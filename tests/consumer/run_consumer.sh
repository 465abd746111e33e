#!/usr/bin/env bash
# run_consumer.sh find_package|add_subdirectory <build dir> <source dir> <generator> <c++ compiler>
# (tests/consumer/CMakeLists.txt). Everything happens in a fresh temporary folder, removed after.
set -euo pipefail
mode=$1 build=$2 source=$3 generator=$4 compiler=$5
work=$(mktemp -d "${TMPDIR:-/tmp}/desslam-consumer.XXXXXX")
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

if [ "$mode" = add_subdirectory ]; then
  cmake -S "$source/tests/consumer/subdirectory" -B "$work/build" -G "$generator" \
        -DCMAKE_CXX_COMPILER="$compiler" -DDESSLAM_SOURCE="$source" > "$work/configure.log" 2>&1 \
    || { cat "$work/configure.log"; fail "configuring a project with DeS-SLAM as a subdirectory"; }
  grep -q '^DESSLAM_BUILD_TESTS:BOOL=OFF' "$work/build/CMakeCache.txt" \
    || fail "DeS-SLAM's tests are built inside another project (DESSLAM_BUILD_TESTS should default to OFF)"
  # DeS-SLAM's program stays in its own binary folder, not where the parent puts its programs.
  if [ "$generator" = Ninja ]; then
    grep -q '^build desslam/apps/desslam:' "$work/build/build.ninja" || fail "desslam program not at desslam/apps/desslam"
    grep -q '^build track_clip:' "$work/build/build.ninja" || fail "no track_clip target"
  fi
  echo "OK: configured and generated with DeS-SLAM as a subdirectory"
  exit 0
fi

prefix=$work/prefix
cmake --install "$build" --prefix "$prefix" > "$work/install.log" || { cat "$work/install.log"; fail "cmake --install"; }
for file in include/desslam/desslam.hpp lib/cmake/desslam/desslamConfig.cmake \
            lib/cmake/desslam/desslamConfigVersion.cmake lib/cmake/desslam/desslamTargets.cmake \
            share/desslam/vocab/desslam_orb_k10l5.bin share/desslam/config/tum_fr1.yaml bin/desslam; do
  [ -e "$prefix/$file" ] || fail "cmake --install did not install $file"
done
ls "$prefix"/lib*/libdesslam.so* > /dev/null 2>&1 || ls "$prefix"/lib/*/libdesslam.so* > /dev/null 2>&1 \
  || fail "no libdesslam.so installed"
internal=$(find "$prefix/include" -type f ! -path "$prefix/include/desslam/*")
[ -z "$internal" ] || fail "internal headers installed: $internal"
echo "installed: $(du -sh "$prefix" | cut -f1) in $prefix"

# DESSLAM_CONSUMER_SANITIZE: the sanitizer flags of a sanitizer build (tests/consumer/CMakeLists.txt).
sanitize=()
[ -z "${DESSLAM_CONSUMER_SANITIZE:-}" ] || sanitize=(-DCMAKE_CXX_FLAGS="$DESSLAM_CONSUMER_SANITIZE"
                                                  -DCMAKE_EXE_LINKER_FLAGS="$DESSLAM_CONSUMER_SANITIZE")
cmake -S "$source/examples/consumer" -B "$work/build" -G "$generator" -DCMAKE_BUILD_TYPE=Release \
      -DCMAKE_CXX_COMPILER="$compiler" -DCMAKE_PREFIX_PATH="$prefix" "${sanitize[@]}" > "$work/configure.log" 2>&1 \
  || { cat "$work/configure.log"; fail "configuring examples/consumer against the installed prefix"; }
cmake --build "$work/build" > "$work/build.log" 2>&1 || { cat "$work/build.log"; fail "building examples/consumer"; }
# The libraries DeS-SLAM uses inside stay inside: the consumer links libdesslam and OpenCV only.
needed=$(readelf -d "$work/build/track_clip" | grep NEEDED || true)
echo "$needed" | grep -q 'libdesslam\.so' || fail "track_clip does not link libdesslam.so: $needed"
if echo "$needed" | grep -Eq 'libceres|libOpen3D|liboctomap|libyaml-cpp|libspdlog|libXNNPACK'; then
  fail "an internal dependency leaks into the consumer: $needed"
fi

clip=${DESSLAM_SHARED_DIR:-$source/../shared}/data/clips/fr1_xyz_0000_0099
# No hint from the environment: the installed library must find its share/desslam by itself.
set +e
env -u DESSLAM_SOURCE_DIR -u DESSLAM_DATA_DIR "$work/build/track_clip" "$clip" tum_fr1 \
    dense.enabled=false dynamic.mode=geometric semantic.segmenter=none > "$work/run.log" 2>&1
rc=$?
set -e
cat "$work/run.log"
[ $rc -eq 77 ] && { echo "SKIPPED: the shared fr1_xyz clip is missing ($clip); set DESSLAM_SHARED_DIR"; exit 77; }
[ $rc -eq 0 ] || fail "track_clip exited with $rc"
grep -q "data folder $prefix/share/desslam\$" "$work/run.log" \
  || fail "the library did not use the installed data folder $prefix/share/desslam"
read -r tracked total < <(sed -n 's/^tracked \([0-9]*\) of \([0-9]*\) frames$/\1 \2/p' "$work/run.log")
[ -n "${total:-}" ] && [ "$total" -gt 0 ] || fail "no 'tracked N of M frames' line"
[ $((tracked * 100)) -ge $((total * 95)) ] || fail "tracked only $tracked of $total frames (< 95 %)"
echo "OK: the consumer tracked $tracked of $total frames against the installed prefix"

# The installed program finds the installed vocabulary too (bin/../share/desslam), from anywhere.
(cd "$work" && env -u DESSLAM_SOURCE_DIR -u DESSLAM_DATA_DIR "$prefix/bin/desslam" run "$clip" \
   --config "$prefix/share/desslam/config/tum_fr1.yaml" --out "$work/run" --max-frames 10 \
   --dynamic geometric --set dense.enabled=false --set semantic.segmenter=none) > "$work/program.log" 2>&1 \
  || { cat "$work/program.log"; fail "the installed bin/desslam could not run"; }
[ -s "$work/run/CameraTrajectory.txt" ] || fail "the installed bin/desslam wrote no trajectory"
echo "OK: the installed bin/desslam ran from $work"
