"""Function length: no function of engine/, server/ or client/ over MAX_LINES lines, but for
the few named below with why. A long function hides several steps under one name; the check
keeps new ones from growing unnoticed.

A small reader of C++, not a compiler (a whole parser for one number is not worth its
dependency): comments, strings (raw ones too) and character literals are blanked, then every
brace is classed by what stands before it since the last ';', '{' or '}'. At namespace or
class scope, a brace after ')' opens a function (its lambdas count in it); after namespace,
class, struct, union or enum a scope; else an initializer. A function's length is the lines
from its '{' to its '}'.

Usage: function_length.py SOURCE_DIR [--max N]     (exit 1 naming each function over)
"""
import argparse
import pathlib
import re
import sys

MAX_LINES = 100
FOLDERS = ("engine", "server", "client", "proto")

# file (from the source folder) and function name -> why it stays one function.
EXCEPTIONS = {
    ("engine/core/src/neighbor_list.cpp", "RebuildPairList"):
        "the hot path's parallel search, join and carry of the springs, kept whole while its "
        "speed is benchmarked as one (issue: physics parts)",
    ("engine/core/src/neighbor_list.cpp", "ResortPairList"):
        "the hot path's parallel re-sort of the near and far pairs, kept whole likewise",
}


def blank(text: str) -> str:
    """The text with comments, strings and character literals replaced by spaces (newlines
    kept, so that line numbers stay)."""
    out = []
    i, n = 0, len(text)
    keep = lambda s: re.sub(r"[^\n]", " ", s)  # noqa: E731
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(keep(text[i:j]))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(keep(text[i:j]))
            i = j
        elif (m := re.compile(r'(?:u8|u|U|L)?R"([^()\\ ]{0,16})\(').match(text, i)) and (
                i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            end = text.find(")" + m.group(1) + '"', m.end())
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append('""' + keep(text[i + 2:j]))
            i = j
        elif c in "\"'":
            # A digit separator (1'000) is no character literal.
            if c == "'" and i > 0 and text[i - 1].isalnum() and i + 1 < n and text[i + 1].isalnum():
                out.append(c)
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            out.append(c + keep(text[i + 1:j]) + c)
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


SCOPE = re.compile(r"\b(namespace|class|struct|union|enum)\b")
# A template's head: its `class` names a parameter, not a scope.
TEMPLATE = re.compile(r"\btemplate\s*<[^{};]*?>")
NAME = re.compile(r"([~A-Za-z_][\w:~<>]*(?:operator\s*\S+?)?)\s*\($")


def functions(text: str):
    """(name, first line, last line) of each function defined at namespace or class scope."""
    code = blank(text)
    stack = []  # "scope", "function", "block" or "init", with a function's name and line
    header_start = 0
    line = 1
    for i, c in enumerate(code):
        if c == "\n":
            line += 1
        elif c in ";":
            header_start = i + 1
        elif c == "{":
            header = code[header_start:i]
            inside = stack[-1][0] if stack else "scope"
            if inside in ("function", "block", "init"):
                kind = "block" if inside != "init" else "init"
                stack.append((kind, None, line))
            elif ")" in header and not SCOPE.search(TEMPLATE.sub("", header).split("(")[0]):
                before = header[:header.find("(") + 1].split()
                m = NAME.search(" ".join(before)) if before else None
                stack.append(("function", m.group(1) if m else "?", line))
            elif SCOPE.search(header):
                stack.append(("scope", None, line))
            else:
                stack.append(("init", None, line))
            header_start = i + 1
        elif c == "}":
            if stack:
                kind, name, first = stack.pop()
                if kind == "function":
                    yield name, first, line
            header_start = i + 1


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("root")
    parser.add_argument("--max", type=int, default=MAX_LINES)
    args = parser.parse_args()
    root = pathlib.Path(args.root)
    over, excused, seen = [], [], set()
    for folder in FOLDERS:
        for path in sorted((root / folder).rglob("*")):
            if path.suffix not in (".cpp", ".h") or "tests" in path.relative_to(root).parts:
                continue
            rel = str(path.relative_to(root))
            for name, first, last in functions(path.read_text(errors="replace")):
                length = last - first + 1
                if length <= args.max:
                    continue
                key = (rel, name)
                if key in EXCEPTIONS:
                    excused.append(f"{rel}:{first} {name}: {length} lines ({EXCEPTIONS[key]})")
                    seen.add(key)
                else:
                    over.append(f"{rel}:{first} {name}: {length} lines")
    for line in excused:
        print(f"excused: {line}")
    # An exception whose function is no longer long goes (one of a file not here is no matter).
    stale = [f"{rel} {name}" for rel, name in EXCEPTIONS
             if (rel, name) not in seen and (root / rel).exists()]
    for name in stale:
        print(f"FAIL: the exception {name} is no longer over {args.max} lines: remove it")
    for line in over:
        print(f"FAIL: over {args.max} lines: {line}")
    if over or stale:
        return 1
    print(f"function length: none over {args.max} lines but the {len(excused)} named")
    return 0


if __name__ == "__main__":
    sys.exit(main())
