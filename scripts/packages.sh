# Shell function shared by scripts/setup.sh and scripts/fuzz.sh (sourced,
# not run).

# vln_install_missing TAG PACKAGE...: installs the Debian packages among
# PACKAGE... that are not installed yet (through sudo unless root), saying
# so as "TAG: installing ...".
vln_install_missing() {
  local tag=$1 p
  shift
  local missing=()
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" ||
      missing+=("$p")
  done
  if ((${#missing[@]})); then
    echo "$tag: installing ${missing[*]}"
    local SUDO=""
    if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
  fi
}
