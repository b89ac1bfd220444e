// Reading small numeric CSV files at a file boundary (a tracker's head poses, a
// recorded pipe motion): one place for the format's rules and its errors.
#pragma once

#include <string>
#include <vector>

namespace hullpipe {

/// One row of numbers and the file line it came from (for messages).
struct CsvRow {
  int line = 0;
  std::vector<double> values;
};

/// Reads `path`: comma-separated numbers, `columns` per row. Empty lines and
/// lines starting with '#' are skipped; the first other line is a header when it
/// is not all numbers. Throws std::runtime_error "path:line: why" for a missing
/// file, a wrong column count (naming `column_names`, e.g. "t,x,y,z"), a cell
/// that is not a number, or a value that is not finite; "path: no rows" when
/// there are none.
std::vector<CsvRow> ReadNumericCsv(const std::string& path, size_t columns, const std::string& column_names);

/// "path:line: " — the prefix of a message about one row.
std::string CsvWhere(const std::string& path, int line);

}  // namespace hullpipe
