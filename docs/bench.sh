#!/usr/bin/env bash
# Re-measure the benchmark pages: each docs/benchmarks/<name>.md is what its `nhsim bench ...` command
# printed, stamped with the date, the commit and the machine (cores, load before and after). Nothing in
# those pages is typed by hand. Usage: docs/bench.sh [NAME ...]   (default: every benchmark below)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
cd "$root"
nhsim=(.venv/bin/python -m sim)

declare -A CMDS=(
    [sim]="bench sim --repeats 5"
    [sim-segmented]="bench sim --tracker segmented --repeats 5"
    [sim-kanayama]="bench sim --tracker kanayama --repeats 5"
    [sim-rpp]="bench sim --tracker rpp --repeats 5"
    [sim-amcl]="bench sim --robot turtlebot3 --localiser amcl --repeats 7"
    [track]="bench track"
    [render]="bench render"
    [plan]="bench plan --seeds 15 --optimal RRTstar --budget 0.05 --no-wheel"
    [plan-optimal]="bench plan --seeds 5 --no-wheel"
    [hybrid]="bench hybrid"
    [optim]="bench optim"
    [simplify]="bench simplify"
    [montecarlo]="bench montecarlo"
    [cold]="bench cold"
    [cold-large]="bench cold --no-crowded --obstacle-scale 2.5 --worlds 3"
    [bag]="bench bag --repeats 5"
)

stamp() {
    printf '%s UTC, commit %s, %s cores, load average %s' "$(date -u '+%Y-%m-%d %H:%M')" \
        "$(git rev-parse --short HEAD)" "$(nproc)" "$(cut -d' ' -f1-3 /proc/loadavg)"
}

names=("$@")
[ ${#names[@]} -gt 0 ] || names=(sim sim-segmented sim-kanayama sim-rpp sim-amcl track render plan plan-optimal hybrid optim simplify montecarlo cold cold-large bag)
for name in "${names[@]}"; do
    cmd="${CMDS[$name]:-}"
    if [ -z "$cmd" ]; then echo "docs/bench.sh: no benchmark '$name' (known: ${!CMDS[*]})" >&2; exit 2; fi
    out="docs/benchmarks/$name.md"
    tmp="$(mktemp "docs/benchmarks/.$name.XXXXXX")"
    trap 'rm -f "$tmp"' EXIT; trap 'rm -f "$tmp"; exit 130' INT TERM  # an interrupted run leaves no half-written page
    before="$(stamp)"
    echo "docs/bench.sh: nhsim $cmd" >&2
    set +e
    # shellcheck disable=SC2086  # a word list
    text="$("${nhsim[@]}" $cmd 2>&1)"  # no bars: stdout is not a terminal
    status=$?
    set -e
    if [ "$status" -eq 130 ]; then  # interrupted: nhsim exits 130 on SIGINT, SIGTERM and SIGHUP (its own handlers)
        rm -f "$tmp"
        echo "docs/bench.sh: nhsim $cmd was interrupted (exit status $status); $out kept as it was" >&2
        exit "$status"
    fi
    {
        echo "# nhsim $cmd"
        echo
        echo "Printed by \`nhsim $cmd\` (exit status $status); started $before; ended with load average $(cut -d' ' -f1-3 /proc/loadavg)."
        echo "Re-measure with \`docs/bench.sh $name\`."
        echo
        echo '```text'
        echo "$text"
        echo '```'
    } > "$tmp"
    chmod 644 "$tmp"  # mktemp makes 0600; a page is read by all
    mv "$tmp" "$out"
done
