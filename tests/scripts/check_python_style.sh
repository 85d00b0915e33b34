#!/usr/bin/env bash
# The Python layout and lint checks (ctest python_format, python_lint) over every Python file of the source
# tree, with the settings of pyproject.toml ([tool.black]) and .flake8. Debian 12's black 23.1 and flake8 5
# (tools/install_deps.sh installs them): other versions may format differently, so a missing tool, or a black
# other than 23, skips the test (exit 77, ctest's SKIP_RETURN_CODE) with a line saying so, rather than passing it.
#   check_python_style.sh format|lint <source dir>
set -euo pipefail
what=$1
cd "$2"
case "$what" in
  format)
    if ! command -v black >/dev/null; then
      echo "python_format skipped: black not found (Debian: apt-get install black; tools/install_deps.sh)"
      exit 77
    fi
    # The tree is laid out by Debian 12's black 23; black 24 and later (Debian 13: 25.1) change the stable
    # style, so with another major version the check is skipped, saying so, rather than failed or passed.
    version=$(black --version | sed -n '1s/^black, \([0-9.]*\).*/\1/p')
    if [ "${version%%.*}" != 23 ]; then
      echo "python_format skipped: black ${version:-of unknown version} lays out differently from black 23," \
        "which the tree is formatted with (Debian 12: apt-get install black)"
      exit 77
    fi
    # black takes the files git would (.gitignore: no build trees, no venv) and prints what it would change.
    if ! black --check --diff --quiet .; then
      echo "Python not formatted as black says (run tools/dev.sh format)" >&2
      exit 1
    fi
    ;;
  lint)
    if ! command -v flake8 >/dev/null; then
      echo "python_lint skipped: flake8 not found (Debian: apt-get install flake8; tools/install_deps.sh)"
      exit 77
    fi
    flake8 .  # .flake8 excludes the build trees and the venv
    ;;
  *)
    echo "usage: check_python_style.sh format|lint <source dir>" >&2
    exit 2
    ;;
esac
