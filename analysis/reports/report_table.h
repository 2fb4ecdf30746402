#pragma once
// The one report table: rows of cells, written in every format veil writes, so that a study
// fills a table once and never writes CSV, Markdown, terminal text or JSON rows by hand.
//
//   study result --rows of Cells--> ReportTable --csv()-->      rank,ghost,flux_W,...
//                                               --markdown()--> | rank | ghost | flux (W) |
//                                               --terminal()--> rank ghost      flux W
//                                               --json()-->     [{"rank": 1, ...}, ...]
//                                               --series()-->   the numbers behind a chart
//
// A cell holds its value as JSON (a number, null where it is not finite, a string, or a nested
// array or object) and its text in each format, so that every format shows the same number the
// way that format shows numbers: CSV full precision, Markdown and the terminal a readable
// rounding, "+-" errors beside values. The factories below cover the common cases; a study may
// set any text itself.
//
// A column says where it appears (a JSON-only column carries a row's nested details, a
// terminal-only column a flag) and how the terminal lays it out: a gap, a width and an
// alignment (a width of 0 leaves the text as it is). Lines never end in blanks.

#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace veil {

struct ReportCell {
    nlohmann::json json;  // the value; discarded() leaves the member out of the row
    std::string csv, markdown, terminal;
    bool quoteCsv = false;  // quote the CSV field even when it needs no quotes

    // The same text everywhere, a JSON string; quoted in CSV when `quote`.
    static ReportCell text(const std::string& s, bool quote = false);
    // A number: `json` the value (null when not finite), each format's text as given.
    static ReportCell number(double value, std::string csv, std::string markdown,
                             std::string terminal);
    // A whole number, the same digits everywhere.
    static ReportCell count(long long n);
    // A yes/no value: JSON true or false, the given words as text.
    static ReportCell flag(bool value, const std::string& yes = "yes", const std::string& no = "no");
    // Leaves the member out of the JSON row (its texts stay).
    ReportCell& withoutJson();
};

enum class Align { Left, Right };

struct ReportColumn {
    ReportColumn() = default;
    ReportColumn(std::string key_, std::string heading_ = "", std::string csvHeader_ = "")
        : key(std::move(key_)), heading(std::move(heading_)), csvHeader(std::move(csvHeader_)) {}

    // The JSON member ("a/b": member b of the row's object a); also the CSV header unless
    // csvHeader is set.
    std::string key;
    std::string heading;          // Markdown heading (and the terminal's unless set below)
    std::string csvHeader;        // empty: key
    std::string terminalHeading;  // empty: heading
    bool csv = true, markdown = true, terminal = true, json = true;
    std::string markdownRule = "---";  // its cell of the |---| line: "---:" aligns right

    ReportColumn withCsvHeader(std::string header) const {
        ReportColumn c = *this;
        c.csvHeader = std::move(header);
        return c;
    }
    // Terminal layout: `gap` before the column, the text padded to `width` (0: as it is).
    std::string gap = "";
    int width = 0;
    Align align = Align::Right;
};

class ReportTable {
  public:
    ReportTable() = default;
    explicit ReportTable(std::vector<ReportColumn> columns) : columns_(std::move(columns)) {}

    void addColumn(ReportColumn c) { columns_.push_back(std::move(c)); }
    // One cell per column, in the columns' order.
    void addRow(std::vector<ReportCell> cells);

    const std::vector<ReportColumn>& columns() const { return columns_; }
    const std::vector<std::vector<ReportCell>>& rows() const { return rows_; }
    size_t columnIndex(const std::string& key) const;  // npos when no column has the key

    // Each format shows the columns that say they appear in it, in the table's order, or
    // exactly the columns `keys` names, in that order (a format that reads best in another
    // order: the ghost table's CSV keeps its Monte Carlo columns together).
    //
    // The header line and a line per row; a field is quoted (its quotes doubled) when its
    // cell asks or its text holds a comma, a quote or a line break.
    std::string csv(const std::vector<std::string>& keys = {}) const;
    // A heading row, the |---| rule and a row per line: "| a | b |".
    std::string markdown(const std::vector<std::string>& keys = {}) const;
    // The heading line and the first `rows` rows (0: all), laid out by the columns.
    std::string terminal(size_t rows = 0, const std::vector<std::string>& keys = {}) const;
    // An array of row objects, one member per JSON column.
    nlohmann::json json() const;
    // The numbers of one column, in row order (NaN where a cell holds none): a chart's data.
    std::vector<double> series(const std::string& key) const;

  private:
    // The columns a format shows: those whose flag is set, or those `keys` names.
    std::vector<size_t> shown(bool ReportColumn::*flag, const std::vector<std::string>& keys) const;

    std::vector<ReportColumn> columns_;
    std::vector<std::vector<ReportCell>> rows_;
};

}  // namespace veil
