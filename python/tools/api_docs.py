"""Writes the API reference of docs/python.md from the package's docstrings (between the
"<!-- api:begin -->" and "<!-- api:end -->" lines).

Run: PYTHONPATH=build/python python3 python/tools/api_docs.py [--check]
(python/tests/test_docs.py checks that the file is current; TURBID_UPDATE_DOCS=1 with that test
rewrites it.)"""
import inspect
import os
import sys

BEGIN, END = "<!-- api:begin -->", "<!-- api:end -->"
DOC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "docs", "python.md")


def _signature(obj):
    try:
        return str(inspect.signature(obj))
    except (TypeError, ValueError):
        return "(...)"


def _doc(obj):
    text = inspect.getdoc(obj) or ""
    return text.strip()


def _entry(title, obj, level):
    lines = ["#" * level + " `" + title + "`", ""]
    doc = _doc(obj)
    if doc:
        lines += [doc, ""]
    return lines


def reference():
    """The generated Markdown (a list of lines)."""
    import turbid
    from turbid import data
    lines = [BEGIN, "",
             "Generated from the docstrings by `python/tools/api_docs.py` (do not edit by hand).",
             ""]
    for module in (turbid, data):
        lines += ["### `%s`" % module.__name__, ""]
        for name in module.__all__:
            if name.startswith("__"):
                continue
            obj = getattr(module, name)
            qual = "%s.%s" % (module.__name__, name)
            if inspect.isclass(obj):
                sig = _signature(obj) if "__init__" in vars(obj) else ""
                if sig.startswith("(core"):  # made by the package's functions, not by users
                    sig = ""
                lines += _entry("class %s%s" % (qual, sig), obj, 4)
                for attr, value in vars(obj).items():
                    if attr.startswith("_"):
                        continue
                    target = value.__func__ if isinstance(value, staticmethod) else value
                    if isinstance(value, property):
                        lines += ["* `%s` (property): %s" % (attr, " ".join(_doc(value).split()))]
                        continue
                    sig = _signature(target).replace("(self, ", "(").replace("(self)", "()")
                    lines += _entry("%s.%s%s" % (qual, attr, sig), target, 5)
                if lines[-1] != "":
                    lines.append("")
            elif callable(obj):
                lines += _entry("%s%s" % (qual, _signature(obj)), obj, 4)
            else:
                lines += ["* `%s = %r`" % (qual, obj), ""]
    lines.append(END)
    return lines


def updated(text):
    """docs/python.md's text with the reference replaced."""
    start, end = text.index(BEGIN), text.index(END) + len(END)
    return text[:start] + "\n".join(reference()) + text[end:]


def main():
    text = open(DOC).read()
    new = updated(text)
    if "--check" in sys.argv:
        if new != text:
            print("docs/python.md: the API reference is out of date; run python/tools/api_docs.py")
            return 1
        return 0
    with open(DOC, "w") as f:
        f.write(new)
    return 0


if __name__ == "__main__":
    sys.exit(main())
