#!/usr/bin/env python3
"""body_lengths.py MAX DIR...: every class or struct body in the C++ files (.cpp, .hpp) under
the DIRs longer than MAX lines, one line each as `PATH:LINE: class|struct NAME is N lines`;
exit 1 if there is one, else 0. Lizard measures functions only; this measures the bodies of
types, from the line of their opening brace to that of the closing one, as lizard counts a
function (both lines included). Comments and strings are skipped when matching braces.
Standard library only (scripts/check_style.sh runs it)."""
import pathlib
import re
import sys

# `class Name`, `struct Name : base`, `template <...> struct Name` up to its `{` (not `;`: a
# declaration; not `struct x y = {`: a variable; not `enum class Name {`).
HEAD = re.compile(r"(?<!enum )\b(class|struct)\s+(\w+)(\s+final)?\s*(:[^;{()=]*)?\{")
TOKENS = re.compile(r'//[^\n]*|/\*.*?\*/|"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\'|[{}]',
                    re.S)


def bodies(text):
    """[(kind, name, first line, line count)] of the class and struct bodies in C++ text."""
    out = []
    for m in HEAD.finditer(text):
        start = m.end() - 1
        depth, pos = 0, start
        for t in TOKENS.finditer(text, start):
            if t.group() == "{":
                depth += 1
            elif t.group() == "}":
                depth -= 1
                if depth == 0:
                    pos = t.start()
                    break
        else:
            continue
        first = text.count("\n", 0, start) + 1
        out.append((m.group(1), m.group(2), first, text.count("\n", start, pos) + 1))
    return out


def main(argv):
    if len(argv) < 2 or not argv[0].isdigit():
        print(__doc__.splitlines()[0], file=sys.stderr)
        return 2
    limit, bad = int(argv[0]), 0
    for d in argv[1:]:
        for path in sorted(pathlib.Path(d).rglob("*")):
            if path.suffix not in (".cpp", ".hpp"):
                continue
            for kind, name, line, n in bodies(path.read_text(errors="replace")):
                if n > limit:
                    print(f"{path}:{line}: {kind} {name} is {n} lines (max {limit})")
                    bad += 1
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
