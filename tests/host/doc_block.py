"""A generated block inside a hand-written doc: the text between two marker lines that a
program renders (the key table, the vocabulary's tables). check() compares the doc's block with
the rendering line by line, or replaces it (--write). Used by check_ini_doc.py and
check_vocab_doc.py. Standard library only."""
import sys


def check(path, text, begin, end, generated, write, what, fix):
    """Exit status: 0 match (or rewritten), 1 differences, 2 markers missing.
    path: the doc (written on write); text: its contents; generated: the rendering;
    what: the counted thing in the last line, e.g. 'keys'; fix: the command that rewrites it."""
    name = path.replace("\\", "/").rsplit("/", 1)[-1]
    try:
        head, rest = text.split(begin + "\n", 1)
        body, tail = rest.split(end, 1)
    except ValueError:
        print(f"{name}: the markers {begin!r} and {end!r} are missing", file=sys.stderr)
        return 2
    if write:
        with open(path, "w", encoding="utf-8") as f:
            f.write(head + begin + "\n" + generated + end + tail)
        print(f"{name}: rewritten from the rendering")
        return 0
    want, have = generated.splitlines(), body.splitlines()
    diffs = [f"line {i + 1}: doc has {h!r}, the rendering gives {w!r}"
             for i, (w, h) in enumerate(zip(want, have)) if w != h]
    if len(want) != len(have):
        diffs.append(f"the doc has {len(have)} lines, the rendering {len(want)}")
    for d in diffs:
        print(d)
    if diffs:
        print(f"{name}: {len(diffs)} differences ({fix})")
        return 1
    print(f"{name}: {len(want)} lines match ({what})")
    return 0
