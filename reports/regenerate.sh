#!/usr/bin/env bash
# Regenerates every committed report under reports/ with the commands their READMEs and
# report.md files name, from the repository's top folder, with the errmap on the PATH (or
# ERRMAP=path/to/errmap). A change that means to change a report runs this, looks at the
# pictures, and commits what changed; `git status reports/` shows it.
set -euo pipefail
cd "$(dirname "$0")/.."
E="${ERRMAP:-errmap}"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$E" demo >/dev/null                                   # reports/demo (the committed subset)
"$E" report-concealed >/dev/null                       # reports/diagnosis
"$E" table datasets/physics/example-session.parquet --out "$tmp/e.csv" --report reports/iso230 >/dev/null
"$E" compare datasets/table1.csv --test datasets/table2.csv --report reports/table2 >/dev/null
"$E" circular diagnose datasets/circular/xy.csv --report reports/circular >/dev/null
"$E" acceptance iso10360 datasets/acceptance/iso10360-example.csv --mpe "1.5+L/333" --report reports/iso10360 >/dev/null
"$E" fuzzy-sim --seed 2013 --trials 200 --report reports/fuzzy-sim >/dev/null
"$E" certificate datasets/physics/example-session.parquet --info datasets/certificate/example-info.toml \
    --out reports/certificate/example-session.pdf >/dev/null
"$E" acceptance iso10360-5 datasets/acceptance/probing-example.csv --sphere datasets/acceptance/probing-sphere.toml \
    --report reports/iso10360-5 >/dev/null 2>&1
"$E" acceptance cmm-certificate --length datasets/acceptance/iso10360-example.csv --mpe "1.5+L/333" --u-um "0.3+L/2000" \
    --mpl-r0 1.2 --probing datasets/acceptance/probing-example.csv --sphere datasets/acceptance/probing-sphere.toml \
    --specification "ACME CMM-X data sheet rev. C" --cmm "ACME CMM-X 10.8.6 S/N 4711" \
    --out reports/iso10360-5/cmm-certificate.pdf >/dev/null 2>&1
echo "regenerated; also: reports/certificate/README.md (the real record), reports/history/F2.png"
echo "(ERRMAP_README_FIGURES=reports/history cargo test --test it sqlite_ledger), reports/live-view/README.md"
