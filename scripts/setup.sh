# Sourced by scripts/main.sh and scripts/test.sh: installs what is missing, then activates
# the virtual environment. Safe to run again: each step is skipped when already done.

# Headless rendering through Mesa (EGL, with OSMesa as a fallback), on Debian and its kin:
# installed as root, else named for the user to install; nothing is asked of sudo.
is_root=false
[ "$(id -u)" -eq 0 ] && is_root=true
apt_install() {  # PACKAGE...: as root, install them; otherwise say how, and fail
  if $is_root; then
    echo "setup: installing Debian packages: $*"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
  else
    echo "setup: missing Debian packages: $*" >&2
    echo "setup: install them as root (sudo apt-get install -y $*), then run this again" >&2
    return 1
  fi
}
if command -v dpkg >/dev/null 2>&1; then
  gl_packages="libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 libosmesa6"
  missing=""
  for package in $gl_packages; do
    dpkg -s "$package" >/dev/null 2>&1 || missing="$missing $package"
  done
  # shellcheck disable=SC2086
  [ -z "$missing" ] || apt_install $missing || return 1
fi

# The virtual environment and the package, reinstalled when pyproject.toml changes.
if [ ! -x .venv/bin/python ]; then
  # Debian's python3 makes a venv only with python3-venv (ensurepip) installed.
  if ! python3 -c "import ensurepip" >/dev/null 2>&1; then
    apt_install python3-venv || return 1
  fi
  echo "setup: creating .venv"
  python3 -m venv .venv
fi
# pip writes the commands it installs with the python it ran as: the real path, not a link to
# .venv (the docs' snippets run in a folder of links), or they break when the link goes.
venv_python="$(cd .venv && pwd -P)/bin/python"
stamp=".venv/.musclecell-$(sha256sum pyproject.toml | cut -c1-16)"
if [ ! -f "$stamp" ]; then
  echo "setup: installing musclecell and its dependencies into .venv"
  "$venv_python" -m pip install -q --upgrade pip
  # torch first, for the learn extra: left to stable-baselines3's requirement, pip would
  # take the newest CUDA build from PyPI (several GB). The documented route is PyTorch's CPU
  # index (README). Where pip's configured indexes or find-links already offer the CPU wheel
  # (an offline mirror, as on the project's machines), it comes from there: the pin's "+cpu"
  # local version matches CPU builds only, so it never pulls a CUDA build, and where no such
  # wheel is offered it fails at once and the CPU index serves.
  if ! "$venv_python" -c "import torch" >/dev/null 2>&1; then
    echo "setup: installing torch (CPU)"
    "$venv_python" -m pip install -q "torch==2.13.0+cpu" 2>/dev/null \
      || "$venv_python" -m pip install -q torch --index-url https://download.pytorch.org/whl/cpu
  fi
  "$venv_python" -m pip install -q -e '.[test,learn,scale,dm,mesh,cad,docs,ros]'
  rm -f .venv/.musclecell-*
  touch "$stamp"
fi
# shellcheck disable=SC1091
source .venv/bin/activate
export MUJOCO_GL="${MUJOCO_GL:-egl}"
