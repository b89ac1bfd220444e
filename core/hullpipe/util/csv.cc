#include "hullpipe/util/csv.h"

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace hullpipe {

std::string CsvWhere(const std::string& path, int line) { return path + ":" + std::to_string(line) + ": "; }

std::vector<CsvRow> ReadNumericCsv(const std::string& path, size_t columns, const std::string& column_names) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::vector<CsvRow> rows;
  std::string line;
  int n = 0;
  bool first = true;  // the first line that is not a comment may be a header
  while (std::getline(in, line)) {
    ++n;
    if (line.empty() || line[0] == '#') continue;
    const bool may_be_header = first;
    first = false;
    CsvRow row;
    row.line = n;
    std::stringstream ss(line);
    std::string cell;
    bool numbers = true;
    while (std::getline(ss, cell, ',')) {
      try {
        row.values.push_back(std::stod(cell));
      } catch (const std::exception&) {
        numbers = false;
        break;
      }
    }
    if (!numbers) {
      if (may_be_header) continue;
      throw std::runtime_error(CsvWhere(path, n) + "not a number: '" + cell + "'");
    }
    if (row.values.size() != columns)
      throw std::runtime_error(CsvWhere(path, n) + "expected " + std::to_string(columns) + " columns " + column_names);
    for (double x : row.values)
      if (!std::isfinite(x)) throw std::runtime_error(CsvWhere(path, n) + "not finite");
    rows.push_back(std::move(row));
  }
  if (rows.empty()) throw std::runtime_error(path + ": no rows");
  return rows;
}

}  // namespace hullpipe
