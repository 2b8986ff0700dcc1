#!/usr/bin/env bash
# Debian packages the PsychoPy sessions and their tests need: a virtual X server, OpenGL, the
# JACK library Psychtoolbox's keyboard loads (PsychoPy's Keyboard times key presses with it),
# Qt's X11 libraries for the participant dialog, xdotool to send real key events in tests
# (setxkbmap to give them another keyboard layout), and
# Chromium with its WebDriver for the test that opens the reports in a real browser, and R for
# the test that reads a report's exported CSVs the way a lab's R script does.
# Installs them with apt-get where it is available and we may use it; otherwise says what is
# missing and leaves the decision to the caller (the window tests then fail with that message).
set -euo pipefail
needed=()
# the library cache read once: `ldconfig -p | grep -q` under pipefail fails at random (grep
# exits at its first match and ldconfig, still writing, dies of SIGPIPE), which reinstalled
# packages that were present
libraries=$(ldconfig -p 2>/dev/null || true)
have_lib() { [[ $libraries == *"$1"* ]]; }
command -v xvfb-run >/dev/null 2>&1 || needed+=(xvfb xauth)
command -v xdotool >/dev/null 2>&1 || needed+=(xdotool)
command -v setxkbmap >/dev/null 2>&1 || needed+=(x11-xkb-utils xkb-data)
command -v chromium >/dev/null 2>&1 || needed+=(chromium)
command -v chromedriver >/dev/null 2>&1 || needed+=(chromium-driver)
command -v Rscript >/dev/null 2>&1 || needed+=(r-base-core)
have_lib 'libGL.so.1' || needed+=(libgl1)
have_lib 'libGLU.so.1' || needed+=(libglu1-mesa)
have_lib 'libjack.so.0' || needed+=(libjack-jackd2-0)
have_lib 'libxcb-cursor.so.0' || needed+=(libxcb-cursor0)
have_lib 'libxkbcommon-x11.so.0' || needed+=(libxkbcommon-x11-0)
have_lib 'libxcb-icccm.so.4' || needed+=(libxcb-icccm4)
have_lib 'libxcb-image.so.0' || needed+=(libxcb-image0)
have_lib 'libxcb-keysyms.so.1' || needed+=(libxcb-keysyms1)
have_lib 'libxcb-render-util.so.0' || needed+=(libxcb-render-util0)
have_lib 'libxcb-xinerama.so.0' || needed+=(libxcb-xinerama0)
have_lib 'libxcb-shape.so.0' || needed+=(libxcb-shape0)
have_lib 'libEGL.so.1' || needed+=(libegl1)
have_lib 'libfontconfig.so.1' || needed+=(libfontconfig1)
have_lib 'libdbus-1.so.3' || needed+=(libdbus-1-3)
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
    echo "warning: cannot install ${needed[*]} (no apt-get or no root); install them to run the window and browser tests" >&2
fi
