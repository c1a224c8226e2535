# Sourced by scripts/main.sh and scripts/test.sh: installs what is missing, then activates
# the virtual environment. Safe to run again: each step is skipped when already done.

# Headless rendering through Mesa (EGL, with OSMesa as a fallback).
gl_packages="libegl1 libegl-mesa0 libgl1-mesa-dri libgbm1 libosmesa6"
missing=""
for package in $gl_packages; do
  dpkg -s "$package" >/dev/null 2>&1 || missing="$missing $package"
done
if [ -n "$missing" ]; then
  echo "setup: installing Debian GL packages:$missing"
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq $missing >/dev/null
fi

# The virtual environment and the package, reinstalled when pyproject.toml changes.
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv"
  python3 -m venv .venv
fi
stamp=".venv/.musclecell-$(sha256sum pyproject.toml | cut -c1-16)"
if [ ! -f "$stamp" ]; then
  echo "setup: installing musclecell and its dependencies into .venv"
  .venv/bin/python -m pip install -q --upgrade pip
  # torch first, for the learn extra: left to stable-baselines3's requirement, pip would
  # take the newest CUDA build from PyPI (several GB); the pin matches the CPU wheel that
  # pip's find-links offer on the project's machines (elsewhere, PyTorch's CPU index:
  # pip install torch --index-url https://download.pytorch.org/whl/cpu).
  if ! .venv/bin/python -c "import torch" >/dev/null 2>&1; then
    echo "setup: installing torch (CPU)"
    .venv/bin/python -m pip install -q "torch==2.13.0"
  fi
  .venv/bin/python -m pip install -q -e '.[test,learn,scale,dm,mesh,cad,docs,ros]'
  rm -f .venv/.musclecell-*
  touch "$stamp"
fi
# shellcheck disable=SC1091
source .venv/bin/activate
export MUJOCO_GL="${MUJOCO_GL:-egl}"
