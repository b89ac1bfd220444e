#!/usr/bin/env bash
# Draws the latency budget as a waterfall (docs/latency.md): one bar per stage
# from where it starts (ms after capture) for its median, a thin line on to its
# p95; stages on the capture-to-composite path dark, the others light.
# Usage: scripts/latency_plot.sh [out/latency.tsv] [docs/images/latency.png] [title]
set -euo pipefail
IN="${1:-out/latency.tsv}"
OUT="${2:-docs/images/latency.png}"
TITLE="${3:-hullpipe latency budget (medians; lines to p95)}"
if [ ! -s "$IN" ]; then
  echo "latency_plot.sh: $IN is missing or empty (render_node writes it beside stats.json)" >&2
  exit 2
fi
ROWS=$(grep -vc '^#' "$IN" || true)
if [ "$ROWS" -lt 1 ]; then
  echo "latency_plot.sh: $IN has no stages" >&2
  exit 2
fi
mkdir -p "$(dirname "$OUT")"
SUBTITLE=$(sed -n 's/^# end to end/end to end/p' "$IN" | head -1)
gnuplot <<GP
set terminal pngcairo size 1100,$((160 + 22 * ROWS)) font "sans,10"
set output "$OUT"
set termoption noenhanced
set title "$TITLE\n$SUBTITLE"
set datafile separator "\t"
set xlabel "ms after the frame's capture time"
set yrange [$ROWS:-1]
set ytics nomirror
set grid xtics
set key below horizontal
set style fill solid 0.9 noborder
plot "$IN" using (\$3 + \$4 / 2):1:(\$3):(\$3 + \$4):(\$1 - 0.35):(\$1 + 0.35):ytic(2) \
       every ::0 with boxxyerror lc rgb "#c7d7ea" title "off the path (beside it)", \
     "" using (\$6 == 1 ? \$3 + \$4 / 2 : 1/0):1:(\$3):(\$3 + \$4):(\$1 - 0.35):(\$1 + 0.35) \
       with boxxyerror lc rgb "#1f5fa8" title "on the capture-to-composite path", \
     "" using (\$3 + \$4):1:(\$3 + \$4):(\$3 + \$5) with xerrorbars pt -1 lc rgb "#444444" title "to p95"
GP
echo "$OUT"
