# SPDX-License-Identifier: Apache-2.0
# Debian package helpers, sourced by the tools/*.sh scripts (not run on its own).

# tvo_deb_installed PKG: true when the package (or PKG:arch) is installed.
tvo_deb_installed() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }

# tvo_apt_ensure TAG PKG...: installs the packages that are missing. As root: apt-get update first (a
# mirror caught mid-sync fails now and then: retried once, then install with what we have); otherwise
# prints what is missing, prefixed with [TAG], and returns 1.
tvo_apt_ensure() {
  local tag="$1" p
  shift
  local need=()
  for p in "$@"; do tvo_deb_installed "$p" || need+=("$p"); done
  [ ${#need[@]} -eq 0 ] && return 0
  if [ "$(id -u)" -ne 0 ]; then
    echo "[$tag] missing Debian packages (run as root to install): ${need[*]}" >&2
    return 1
  fi
  echo "[$tag] apt-get install ${need[*]}"
  apt-get update -qq || { sleep 10; apt-get update -qq; } || echo "[$tag] apt-get update incomplete, continuing" >&2
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
}
