"""The per-case table of an out-of-vocabulary self-check run, read from its cases' diagnosis.json.

    python3 oov_table.py DIR/cases      (DIR: a diagnose-selfcheck --out folder)

Prints one Markdown row per case: verdict, the best candidate (its group after ' ≈ '), its shrink,
the significant cells it leaves and `remainder.reason`.
"""
import json
import pathlib
import sys


def label(r):
    # A pair names both effects (`a+b`); effects the data cannot tell from it follow ` ≈ `.
    name = "+".join(r.get("effects") or [r["effect"]])
    return " ≈ ".join([name] + [g for g in (r.get("group") or []) if g != name])


def main(cases_dir):
    rows = []
    for case in sorted(pathlib.Path(cases_dir).iterdir()):
        for path in (case / "diagnosis.json", case / "diagnosis" / "diagnosis.json"):
            if path.exists():
                break
        else:
            continue
        d = json.loads(path.read_text())
        rem = d.get("remainder", {})
        best = d["ranking"][0] if d.get("ranking") else None
        left = rem.get("cells")
        if isinstance(left, list):
            left = len(left)
        rows.append(
            "| {} | `{}` | {} | {} | {} | {} | `{}` |".format(
                case.name,
                d["verdict"],
                f"{d['gap']['total']:.1f}",
                f"`{label(best)}`" if best else "–",
                f"{best['shrink']:.2f}" if best else "–",
                "–" if left is None else left,
                rem.get("reason", "–"),
            )
        )
    print("| case | verdict | D₀ | best candidate | shrink | significant cells left | reason |")
    print("|---|---|---|---|---|---|---|")
    print("\n".join(rows))


if __name__ == "__main__":
    main(sys.argv[1])
