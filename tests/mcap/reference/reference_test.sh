#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The files RTM writes, read by the MCAP format's reference readers (npm: @mcap/core, and
# @foxglove/omgidl-serialization decoding each message with its omgidl schema): for each chunk
# compression, both the indexed and the stream reader decode every message as it was written;
# a time range gives its messages; a file cut short is refused by both, and the file recovered
# from it is whole again and holds every message of its whole chunks.
# usage: reference_test.sh READER_DIR REFERENCE_WRITER
set -euo pipefail
reader_dir=${1:?usage: reference_test.sh READER_DIR REFERENCE_WRITER}
writer=${2:?usage: reference_test.sh READER_DIR REFERENCE_WRITER}
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d "${TMPDIR:-/tmp}/rtm-mcap-ref.XXXXXX")
trap 'rm -rf "$work"' EXIT
read_mcap() { node "$reader_dir/read.mjs" "$@"; }

for compression in none lz4 zstd; do
  file=$work/$compression.mcap
  "$writer" write "$file" "$compression" "$work/expected.json"
  read_mcap "$file" >"$work/indexed.json"
  python3 "$here/compare.py" "$work/expected.json" "$work/indexed.json"
  read_mcap "$file" --stream >"$work/stream.json"
  python3 "$here/compare.py" "$work/expected.json" "$work/stream.json"
  python3 - "$work/indexed.json" "$compression" <<'PY'
import json, sys
got = json.load(open(sys.argv[1]))
names = sorted(s["name"] for s in got["schemas"])
assert names == sorted(["RTM::TimedFloat6", "RTM::TimedDoubleSeq", "RtmTest::TimedPose", "RtmTest::TimedMixed",
                        "RtmTest::TimedScalars", "RtmTest::TimedPath"]), names
assert all(s["encoding"] == "omgidl" for s in got["schemas"])
assert all(c["messageEncoding"] == "cdr" for c in got["channels"])
assert got["metadata"] == [{"name": "system", "metadata": {"components": "sensor0 controller0"}}], got["metadata"]
assert int(got["statistics"]["messageCount"]) == len(got["messages"]), got["statistics"]
assert got["chunkIndexes"] > 1, got["chunkIndexes"]
print(f"{sys.argv[2]}: {len(got['messages'])} messages, {got['chunkIndexes']} chunks, schemas and metadata as written")
PY
done

# A range: exactly the messages whose log time is in it.
file=$work/zstd.mcap
start=$(python3 -c "import json; print(json.load(open('$work/expected.json'))['messages'][10]['logTime'])")
end=$(python3 -c "import json; print(json.load(open('$work/expected.json'))['messages'][29]['logTime'])")
read_mcap "$file" --start "$start" --end "$end" >"$work/range.json"
python3 - "$work/expected.json" "$work/range.json" <<'PY'
import json, sys
want = json.load(open(sys.argv[1]))["messages"][10:30]
got = json.load(open(sys.argv[2]))["messages"]
assert [m["sequence"] for m in got] == [m["sequence"] for m in want], [m["sequence"] for m in got]
print(f"range: {len(got)} messages, the ones in it")
PY

# Cut short: refused by both readers; recovered: whole again.
size=$(stat -c %s "$file")
head -c $((size * 3 / 5)) "$file" >"$work/cut.mcap"
if read_mcap "$work/cut.mcap" >/dev/null 2>"$work/err"; then
  echo "the indexed reader read a cut file"; exit 1
fi
if read_mcap "$work/cut.mcap" --stream >/dev/null 2>>"$work/err"; then
  echo "the stream reader read a cut file"; exit 1
fi
recovered=$("$writer" recover "$work/cut.mcap" "$work/fixed.mcap")
((recovered > 0)) || { echo "nothing recovered"; exit 1; }
read_mcap "$work/fixed.mcap" >"$work/fixed.json"
python3 "$here/compare.py" --first "$recovered" "$work/expected.json" "$work/fixed.json"
read_mcap "$work/fixed.mcap" --stream >/dev/null
echo "cut at $((size * 3 / 5)) of $size bytes: refused, then $recovered messages recovered into a whole file"
