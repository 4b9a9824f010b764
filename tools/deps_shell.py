"""The programs a shell script starts: the command words of its simple
commands, found by a small tokenizer over `bash --pretty-print`'s normal form
(comments gone, one syntax), recursing into $(...), `...`, <(...) and heredocs
fed to a shell. Used by tools/check-deps.

It errs on the side of finding too much: a word in command position that
names no program is dropped later (tools/check-deps resolves the words with
the PATH of a Debian login and ignores builtins and the scripts' functions).
"""

import re
import subprocess

_REDIRS = {"<", ">", ">>", "<<<", "<&", ">&", "&>", "&>>", ">|", "<>", "<<", "<<-"}
_SEPARATORS = {";", "&", "&&", "||", "|", "|&", "(", ")", ";;", ";&", ";;&", "!", "\n"}
_OPERATORS = sorted(_REDIRS | _SEPARATORS - {"\n"}, key=len, reverse=True)
_KEYWORDS_BEFORE_COMMAND = {"then", "do", "else", "elif", "if", "while", "until", "time", "!", "{", "}",
                            "fi", "done", "esac"}
# Wrappers run the command that follows their options (and, for timeout, a duration).
_WRAPPERS = {"timeout": 1, "env": 0, "exec": 0, "command": 0, "nohup": 0, "setsid": 0, "sudo": 0,
             "nice": 0, "stdbuf": 0, "xargs": 0, "chrt": 1, "taskset": 1}
_ASSIGNMENT = re.compile(r"^[A-Za-z_]\w*(\[[^\]]*\])?\+?=")
_FD = re.compile(r"^(\d+|\{\w+\})$")
_HEREDOC = re.compile(r"<<-?\s*(['\"]?)(\w+)\1")


def pretty(path):
    """bash's normal form of the script, or its text when bash cannot parse it."""
    r = subprocess.run(["bash", "--pretty-print", str(path)], capture_output=True, text=True)
    return r.stdout if r.returncode == 0 and r.stdout.strip() else path.read_text()


def split_heredocs(text):
    """(text without heredoc bodies, [(command line, body)])."""
    out, bodies, lines, i = [], [], text.split("\n"), 0
    while i < len(lines):
        line = lines[i]
        out.append(line)
        i += 1
        for _, delim in _HEREDOC.findall(line):
            body = []
            while i < len(lines) and lines[i].strip() != delim:
                body.append(lines[i])
                i += 1
            i += 1
            bodies.append((line, "\n".join(body)))
    return "\n".join(out), bodies


def _closing(text, i, pair="()"):
    """Index of the `)` (or pair[1]) matching the `(` at i (quotes respected)."""
    depth, n = 0, len(text)
    while i < n:
        c = text[i]
        if c == "\\":
            i += 2
            continue
        if c == "'":
            i = text.find("'", i + 1) if text.find("'", i + 1) >= 0 else n
        elif c == pair[0]:
            depth += 1
        elif c == pair[1]:
            depth -= 1
            if depth == 0:
                return i
        i += 1
    return n


def tokens(text, nested):
    """Words (str) and operators (tuple) of `text`; code in substitutions goes to `nested`."""
    out, word, quoted, i, n = [], [], False, 0, len(text)

    def flush():
        nonlocal word, quoted
        if word or quoted:
            out.append("".join(word))
        word, quoted = [], False

    while i < n:
        c = text[i]
        if c == "\\":
            word.append(text[i + 1:i + 2])
            i += 2
        elif c == "'":
            j = text.find("'", i + 1)
            j = n if j < 0 else j
            word.append(text[i + 1:j])
            quoted, i = True, j + 1
        elif c == '"':
            j = i + 1
            while j < n and text[j] != '"':
                if text[j] == "\\":
                    j += 1
                elif text.startswith("$(", j):
                    k = _closing(text, j + 1)
                    nested.append(("code", text[j + 2:k]))
                    word.append("$(...)")
                    j = k
                elif text[j] == "`":
                    k = text.find("`", j + 1)
                    nested.append(("code", text[j + 1:k]))
                    j = k
                else:
                    word.append(text[j])
                j += 1
            quoted, i = True, j + 1
        elif text.startswith("${", i):
            k = _closing(text, i + 1, "{}")
            nested.append(("param", text[i + 2:k]))
            word.append("${...}")
            i = k + 1
        elif c == "(" and word and word[-1].endswith("="):
            k = _closing(text, i)  # array assignment: a=(...)
            word.append(text[i:k + 1])
            i = k + 1
        elif text.startswith("$(", i) or (not word and text[i:i + 2] in ("<(", ">(")):
            k = _closing(text, i + 1)
            nested.append(("code", text[i + 2:k]))
            word.append("$(...)")
            i = k + 1
        elif c == "`":
            k = text.find("`", i + 1)
            k = n if k < 0 else k
            nested.append(("code", text[i + 1:k]))
            word.append("$(...)")
            i = k + 1
        elif c == "#" and not word:
            while i < n and text[i] != "\n":
                i += 1
        elif c in " \t":
            flush()
            i += 1
        elif c == "\n":
            flush()
            out.append(("\n",))
            i += 1
        elif c in ";&|()<>":
            if c in "<>" and _FD.match("".join(word)):
                word, quoted = [], False  # 2> or {fd}<: part of the redirection
            flush()
            if text.startswith("((", i):
                k = text.find("))", i)  # arithmetic command: no program in it but $(...)
                k = n if k < 0 else k
                tokens(text[i + 2:k], nested)
                i = k + 2
                continue
            op = next(o for o in _OPERATORS + [c] if text.startswith(o, i))
            out.append((op,))
            i += len(op)
        else:
            word.append(c)
            i += 1
    flush()
    return out


def command_words(text):
    """The literal first words of the simple commands in `text`, with the
    variable names used as commands (`"$PY" ...` gives "$PY")."""
    found, todo = [], [("code", text)]
    while todo:
        nested = []
        kind, chunk = todo.pop()
        # $((...)) and ${...} run no command, but may hold substitutions.
        words = _first_words(tokens(chunk, nested))
        if kind == "code" and not chunk.startswith("("):
            found += words
        todo += nested
    return found


def _first_words(toks):
    found, command_pos, skip_target, in_test = [], True, False, False
    case_header, patterns, wrapper_args = False, False, None
    for t in toks:
        if isinstance(t, tuple):
            op = t[0]
            if op in _REDIRS:
                skip_target = True
            elif op == ")" and patterns:
                patterns, command_pos = False, True
            elif op in _SEPARATORS:
                command_pos, wrapper_args = True, None
                patterns = patterns or op in (";;", ";&", ";;&")
            continue
        if skip_target:
            skip_target = False
        elif in_test:
            in_test = t != "]]"
        elif patterns:
            patterns = t != "esac"
        elif not command_pos:
            if t == "in" and case_header:
                case_header, patterns = False, True
        elif wrapper_args is not None and (t.startswith("-") or _ASSIGNMENT.match(t)):
            continue
        elif wrapper_args:
            wrapper_args -= 1
        elif t == "[[":
            in_test = True
        elif t in _KEYWORDS_BEFORE_COMMAND or _ASSIGNMENT.match(t):
            continue
        elif t in ("case", "for", "select", "function"):
            case_header, command_pos = t == "case", False
        else:
            found.append(t)
            wrapper_args = _WRAPPERS.get(t)
            command_pos = wrapper_args is not None
    return found


def functions(text):
    """Names of the shell functions `text` defines."""
    return set(re.findall(r"(?m)(?:^|[;{&|]\s*)\s*(?:function\s+)?([\w.:-]+)\s*\(\)", text))


def path_variables(text):
    """Variables assigned a literal absolute path: {"PY": "/usr/bin/python3"}."""
    return dict(re.findall(r"(?m)^\s*(?:local\s+|export\s+|readonly\s+)?([A-Za-z_]\w*)=['\"]?(/[\w/.+-]+)['\"]?\s*$", text))
