#!/usr/bin/env bash
# Test of deploy/lint.sh on a scratch git repository with the project's .clang-format and .clang-tidy and a
# hand-written compile_commands.json: a first commit (every file linted), a clean commit, a commit with a
# format violation (caught, named, fixed by --fix), one with a clang-tidy finding (caught), --base, a
# header-only change, and a shallow clone without HEAD's parent (skipped, exit 77).
# Usage: deploy/lint_test.sh WORKDIR
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
src=$(cd "$here/.." && pwd)
work=${1:?usage: lint_test.sh WORKDIR}
rm -rf "$work"
mkdir -p "$work/repo/build"
cd "$work/repo"

fail() { echo "FAIL: $*" >&2; exit 1; }
# expect RC REGEX -- ARGS...: runs lint.sh ARGS in the current directory, checks exit code and output.
expect() {
  local want=$1 re=$2
  shift 3
  local out rc=0
  out=$("$src/deploy/lint.sh" "$@" 2>&1) || rc=$?
  [ "$rc" = "$want" ] || fail "lint.sh $*: exit $rc, expected $want:"$'\n'"$out"
  grep -qE -- "$re" <<<"$out" || fail "lint.sh $*: no line matches '$re':"$'\n'"$out"
  echo "ok: lint.sh $* -> $rc ($re)"
}

git init -q -b main .
git config user.email lint@test
git config user.name lint-test
cp "$src/.clang-format" "$src/.clang-tidy" .
printf '/build/\n' > .gitignore
mkdir -p proto/src
cat > proto/src/good.c <<'EOF'
#include <string.h>

int vc_good(char* buf, int n);

int vc_good(char* buf, int n) {
  memset(buf, 0, (size_t)n);
  return n;
}
EOF
cat > build/compile_commands.json <<EOF
[
{ "directory": "$work/repo/build", "command": "clang -std=c11 -c $work/repo/proto/src/good.c -o good.o",
  "file": "$work/repo/proto/src/good.c" },
{ "directory": "$work/repo/build", "command": "clang -std=c11 -c $work/repo/proto/src/bad_tidy.c -o bad.o",
  "file": "$work/repo/proto/src/bad_tidy.c" }
]
EOF
git add -A
git commit -qm first
expect 0 "1 C/C\+\+ files of the first commit" -- --build build
expect 0 "clang-tidy: ok \(1 files\)" -- --build build

# A commit that changes no C/C++ file.
echo "notes" > README.md
git add README.md && git commit -qm readme
expect 0 "no C/C\+\+ file changed by the last commit" -- --build build

# A badly formatted file: named, with the fix; --fix formats it; then clean.
printf 'int vc_ugly( int  x ){return x+1;}\n' > proto/src/ugly.c
git add -A && git commit -qm ugly
expect 1 "clang-format: 1 files are not formatted" -- --build build --no-tidy
expect 1 "^  proto/src/ugly.c$" -- --build build --no-tidy
expect 0 "formatted 1 files" -- --build build --fix --no-tidy
expect 0 "clang-format: ok" -- --build build --no-tidy
git commit -qam "ugly: formatted"

# A clang-tidy finding (bugprone-branch-clone: both branches do the same).
cat > proto/src/bad_tidy.c <<'EOF'
int vc_pick(int x);

int vc_pick(int x) {
  int a;
  if (x)
    a = 1;
  else
    a = 1;
  return a;
}
EOF
git add -A && git commit -qm "bad tidy"
expect 1 "bad_tidy.c:5:3: error: if with identical then and else branches \\[bugprone-branch-clone" -- --build build
expect 1 "clang-tidy: findings in 1 of 1 files: proto/src/bad_tidy.c" -- --build build
expect 0 "clang-format: ok" -- --build build --no-tidy
# Uncommitted changes count: the fix makes it pass before it is committed.
sed -i '0,/    a = 1;/s//    a = 2;/' proto/src/bad_tidy.c
expect 0 "clang-tidy: ok \\(1 files\\)" -- --build build
git commit -qam "bad tidy: fixed"

# --base: everything since the first commit (ugly.c, bad_tidy.c; good.c has not changed).
expect 0 "2 C/C\+\+ files changed since [0-9a-f]+ \(merge base with main~5\)" -- --build build --base main~5
expect 2 "no commit nosuchref" -- --build build --base nosuchref

# A header alone: format-checked, not given to clang-tidy by itself.
printf '#pragma once\nint vc_h(void);\n' > proto/src/h.h
git add -A && git commit -qm header
expect 0 "clang-tidy: ok \(0 files\)" -- --build build

# A missing build: a clear error, not a pass.
expect 2 "no build directory" -- --build nowhere

# A shallow clone of depth 1: HEAD's parent is missing; skipped with the reason (CTest: SKIP_RETURN_CODE).
git clone -q --depth 1 "file://$work/repo" "$work/shallow"
mkdir -p "$work/shallow/build"
cp build/compile_commands.json "$work/shallow/build/"
cd "$work/shallow"
expect 77 "skipped: HEAD's parent is not in this shallow clone" -- --build build
# Files given explicitly still work there.
expect 0 "clang-format: ok" -- --build build --no-tidy proto/src/good.c

cd / && rm -rf "$work"
echo "lint.sh: all cases pass"
