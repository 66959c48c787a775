#!/usr/bin/env bash
# Lints the C/C++ files changed relative to a base: clang-format on whole files (--dry-run -Werror, the
# root .clang-format) and clang-tidy (the root .clang-tidy, every warning an error) with the build's
# compile_commands.json. CTest runs it as the test `lint` (label unit), so `.ci/run` checks every commit.
#
#   deploy/lint.sh [--base REF] [--build DIR] [--fix] [--no-tidy] [FILE...]
#
#   --base REF   lint the files changed since the merge base of REF and HEAD. Default: since HEAD's
#                parent, i.e. the files the last commit changed. Uncommitted changes to tracked files
#                and untracked files count too. On a repository's first commit: every file of it.
#   --build DIR  the configured build whose compile_commands.json clang-tidy reads (default build/ci).
#   --fix        rewrite the files with clang-format instead of checking their format.
#   --no-tidy    only the format check.
#   FILE...      lint these files instead of the changed ones.
#
# clang-tidy runs on the changed .c/.cpp files the build compiles; headers are checked through them
# (.clang-tidy's HeaderFilterRegex). Exit: 0 clean, 1 findings, 2 bad usage or missing tools or build,
# 77 skipped (not a git work tree, or a shallow clone without the base; CTest shows it as skipped).
set -uo pipefail

usage() { sed -n '/^#   deploy\/lint.sh/,/^#   FILE/p' "$0" | sed 's/^# \{0,1\}//' >&2; exit 2; }
die() { echo "lint: $*" >&2; exit 2; }
skip() { echo "lint: skipped: $*" >&2; exit 77; }

base_ref="" build="" fix=0 tidy=1 files=()
while [ $# -gt 0 ]; do
  case "$1" in
    --base) [ $# -ge 2 ] || usage; base_ref=$2; shift 2 ;;
    --build) [ $# -ge 2 ] || usage; build=$2; shift 2 ;;
    --fix) fix=1; shift ;;
    --no-tidy) tidy=0; shift ;;
    -h|--help) usage ;;
    --) shift; files+=("$@"); break ;;
    -*) echo "lint: unknown option $1" >&2; usage ;;
    *) files+=("$1"); shift ;;
  esac
done

here=$(cd "$(dirname "$0")" && pwd)
CLANG_FORMAT=${CLANG_FORMAT:-clang-format}
CLANG_TIDY=${CLANG_TIDY:-clang-tidy}
command -v "$CLANG_FORMAT" >/dev/null || die "$CLANG_FORMAT not found (deploy/install-deps.sh installs it)"

if ! root=$(git rev-parse --show-toplevel 2>&1); then
  case "$root" in
    *"dubious ownership"*) die "git refuses this repository: ${root#fatal: }" ;;
    *) skip "$(pwd) is not in a git work tree" ;;
  esac
fi
cd "$root" || die "cannot enter $root"
build=${build:-build/ci}
build=$(cd "$build" 2>/dev/null && pwd) || die "no build directory ${build} (configure first: cmake --preset ci)"

# ---- which files --------------------------------------------------------------------------------------
if [ ${#files[@]} -eq 0 ]; then
  if [ -n "$base_ref" ]; then
    git rev-parse -q --verify "${base_ref}^{commit}" >/dev/null ||
      { [ "$(git rev-parse --is-shallow-repository)" = true ] && skip "$base_ref is not in this shallow clone"; } ||
      die "no commit $base_ref"
    base=$(git merge-base "$base_ref" HEAD) ||
      { [ "$(git rev-parse --is-shallow-repository)" = true ] &&
          skip "the merge base of $base_ref and HEAD is not in this shallow clone (git fetch --unshallow)"; } ||
      die "$base_ref and HEAD have no merge base"
    what="changed since $(git rev-parse --short "$base") (merge base with $base_ref)"
  elif base=$(git rev-parse -q --verify "HEAD^1"); then
    what="changed by the last commit $(git rev-parse --short HEAD)"
  elif [ "$(git rev-parse --is-shallow-repository)" = true ]; then
    skip "HEAD's parent is not in this shallow clone: fetch it (git fetch --deepen=1) or pass --base REF"
  elif git rev-parse -q --verify HEAD >/dev/null; then
    base=$(git hash-object -t tree /dev/null)  # the first commit: every file it holds is new
    what="of the first commit $(git rev-parse --short HEAD)"
  else
    base=$(git hash-object -t tree /dev/null)  # no commit yet
    what="of the work tree (no commit yet)"
  fi
  mapfile -t files < <({ git diff --name-only --diff-filter=ACMR "$base" -- 2>/dev/null
                         git ls-files --others --exclude-standard; } | sort -u)
else
  what="given"
fi

sources=()
for f in "${files[@]}"; do
  case "$f" in
    *.c|*.h|*.cc|*.cpp|*.hpp) [ -f "$f" ] && sources+=("$f") ;;
  esac
done
if [ ${#sources[@]} -eq 0 ]; then
  echo "lint: no C/C++ file ${what}"
  exit 0
fi
echo "lint: ${#sources[@]} C/C++ files ${what}"

failed=0

# ---- clang-format: whole files ---------------------------------------------------------------------------
if [ $fix -eq 1 ]; then
  "$CLANG_FORMAT" -i --style=file "${sources[@]}" || die "$CLANG_FORMAT failed"
  echo "lint: formatted ${#sources[@]} files"
else
  bad_format=()
  for f in "${sources[@]}"; do
    "$CLANG_FORMAT" --dry-run -Werror --style=file "$f" >/dev/null 2>&1 || bad_format+=("$f")
  done
  if [ ${#bad_format[@]} -gt 0 ]; then
    failed=1
    "$CLANG_FORMAT" --dry-run --style=file "${bad_format[0]}" 2>&1 | head -n 20
    echo "lint: clang-format: ${#bad_format[@]} files are not formatted (fix: deploy/lint.sh --fix ...):"
    printf '  %s\n' "${bad_format[@]}"
  else
    echo "lint: clang-format: ok"
  fi
fi

# ---- clang-tidy: the sources the build compiles ------------------------------------------------------------
if [ $tidy -eq 1 ]; then
  command -v "$CLANG_TIDY" >/dev/null || die "$CLANG_TIDY not found (deploy/install-deps.sh installs it)"
  [ -f "$build/compile_commands.json" ] || die "no $build/compile_commands.json (configure first: cmake --preset ci)"
  # One compile command per file (targets such as the fuzzers compile some sources a second time).
  db=$(mktemp -d) || die "mktemp failed"
  trap 'rm -rf "$db"' EXIT
  cmake -DIN="$build/compile_commands.json" -DOUT="$db/compile_commands.json" \
    -P "$here/cmake/compdb_unique.cmake" || die "cannot read $build/compile_commands.json"
  tidy_files=() not_built=()
  for f in "${sources[@]}"; do
    case "$f" in *.h|*.hpp) continue ;; esac
    re=$(printf '%s' "$root/$f" | sed 's/[][\.*^$+?(){}|]/\\&/g')
    if grep -qE "\"file\" ?: ?\"$re\"" "$db/compile_commands.json"; then tidy_files+=("$f"); else not_built+=("$f"); fi
  done
  [ ${#not_built[@]} -gt 0 ] && echo "lint: clang-tidy: not compiled in $build, format only: ${not_built[*]}"
  bad_tidy=()
  for f in "${tidy_files[@]}"; do
    out=$("$CLANG_TIDY" -p "$db" --quiet --warnings-as-errors='*' "$f" 2>&1)
    rc=$?
    if [ $rc -ne 0 ] || grep -q "warning:\|error:" <<<"$out"; then
      bad_tidy+=("$f")
      grep -v "^[0-9]* warnings\? generated\.$\|^[0-9]* warnings\? and [0-9]* errors\? generated\.$" <<<"$out"
    fi
  done
  if [ ${#bad_tidy[@]} -gt 0 ]; then
    failed=1
    echo "lint: clang-tidy: findings in ${#bad_tidy[@]} of ${#tidy_files[@]} files: ${bad_tidy[*]}"
  else
    echo "lint: clang-tidy: ok (${#tidy_files[@]} files)"
  fi
fi

exit $failed
