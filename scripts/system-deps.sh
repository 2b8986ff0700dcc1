#!/usr/bin/env bash
# Debian packages the PsychoPy window tests need: a virtual X server and OpenGL.
# Installs them with apt-get where it is available and we may use it; otherwise says what is
# missing and leaves the decision to the caller (the window tests then fail with that message).
set -euo pipefail
needed=()
command -v xvfb-run >/dev/null 2>&1 || needed+=(xvfb xauth)
ldconfig -p 2>/dev/null | grep -q 'libGL.so.1' || needed+=(libgl1)
ldconfig -p 2>/dev/null | grep -q 'libGLU.so.1' || needed+=(libglu1-mesa)
if [ ${#needed[@]} -eq 0 ]; then
    exit 0
fi
if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
    echo "installing Debian packages: ${needed[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${needed[@]}" >/dev/null
elif command -v apt-get >/dev/null 2>&1 && command -v sudo >/dev/null 2>&1; then
    echo "installing Debian packages with sudo: ${needed[*]}"
    sudo apt-get update -qq
    sudo DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${needed[@]}" >/dev/null
else
    echo "warning: cannot install ${needed[*]} (no apt-get or no root); install them to run the window tests" >&2
fi
