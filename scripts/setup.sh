#!/usr/bin/env bash
# Installs what hybrid needs on Debian: Embree (libembree-dev: Embree 3 on
# Debian 12, Embree 4 on Debian 13) and libclang (libclang-dev, for
# bindgen), and gcc for the plain-C Embree driver. As root it installs them; otherwise it prints the exact command
# and stops. On Debian 12, which has no Embree 4 package, it also puts the
# Embree 4.4 that the `embreex` wheel on PyPI ships (Intel's
# libembree4.so.4 and its libtbb.so.12) in ~/.local/lib/hybrid/embree4,
# where hybrid looks for it (set HYBRID_EMBREE4 to use another copy).
set -euo pipefail

missing=()
for pkg in libembree-dev libclang-dev pkg-config unzip gcc; do
  dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
done

if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" = 0 ]; then
    echo "setup: installing ${missing[*]}" >&2
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq "${missing[@]}" >/dev/null
  else
    echo "setup: missing Debian packages: ${missing[*]}" >&2
    echo "setup: run: sudo apt-get update && sudo apt-get install -y ${missing[*]}" >&2
    exit 1
  fi
fi

if ! command -v cargo >/dev/null 2>&1; then
  echo "setup: cargo is not on PATH; install Rust (rustup) first" >&2
  exit 1
fi

# Embree 4: the system's (Debian 13, Intel's release on the loader's path),
# else the wheel's, fetched once.
wheel=embreex-4.4.0.post1-cp311-cp311-manylinux_2_27_x86_64.manylinux_2_28_x86_64.whl
wheel_sha256=2cd0f7d5c6342e6247e31f700761689cae7829454d8c6de0c41e62124a023e1f
dir="$HOME/.local/lib/hybrid/embree4"
if [ -n "${HYBRID_EMBREE4:-}" ] || ldconfig -p 2>/dev/null | grep -q 'libembree4\.so\.4 ' || [ -e "$dir/libembree4.so.4" ]; then
  :
elif [ "$(uname -m)" != x86_64 ]; then
  echo "setup: no Embree 4 here and the embreex wheel is x86_64 only; hybrid runs with Embree 3 (install Embree 4 and set HYBRID_EMBREE4 to add it)" >&2
elif ! python3 -m pip --version >/dev/null 2>&1; then
  echo "setup: Embree 4 comes from the embreex wheel on PyPI, which needs pip: run apt-get install -y python3-pip, then this script again" >&2
  exit 1
else
  echo "setup: fetching Embree 4.4 (the embreex $wheel wheel) into $dir" >&2
  tmp=$(mktemp -d)
  trap 'rm -rf "$tmp"' EXIT
  python3 -m pip download --quiet --no-deps --only-binary=:all: \
    --python-version 3.11 --platform manylinux_2_28_x86_64 \
    -d "$tmp" embreex==4.4.0.post1 >&2
  echo "$wheel_sha256  $tmp/$wheel" | sha256sum --check --quiet
  unzip -q -j "$tmp/$wheel" 'embreex.libs/*' -d "$tmp/libs"
  mkdir -p "$dir"
  # The wheel renamed both libraries; Embree finds its TBB beside it
  # (RPATH $ORIGIN), so the two stay together under their own names.
  cp "$tmp"/libs/libembree4-*.so.4 "$tmp"/libs/libtbb-*.so.12 "$dir/"
  ln -sf "$(basename "$(ls "$dir"/libembree4-*.so.4 | head -n 1)")" "$dir/libembree4.so.4"
fi
