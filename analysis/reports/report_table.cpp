#include "analysis/reports/report_table.h"

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace veil {

namespace {

// Marks a cell whose member the JSON row leaves out.
const nlohmann::json& discarded() {
    static const nlohmann::json d = nlohmann::json::value_t::discarded;
    return d;
}

std::string csvField(const ReportCell& c) {
    const bool needs = c.csv.find_first_of(",\"\n\r") != std::string::npos;
    if (!c.quoteCsv && !needs) return c.csv;
    std::string out = "\"";
    for (char ch : c.csv) out += ch == '"' ? std::string("\"\"") : std::string(1, ch);
    return out + "\"";
}

std::string pad(const std::string& s, int width, Align align) {
    if (width <= 0 || static_cast<int>(s.size()) >= width) return s;
    const std::string fill(static_cast<size_t>(width) - s.size(), ' ');
    return align == Align::Left ? s + fill : fill + s;
}

std::string rstrip(std::string s) {
    s.erase(s.find_last_not_of(' ') + 1);
    return s;
}

}  // namespace

ReportCell ReportCell::text(const std::string& s, bool quote) {
    ReportCell c;
    c.json = s;
    c.csv = c.markdown = c.terminal = s;
    c.quoteCsv = quote;
    return c;
}

ReportCell ReportCell::number(double value, std::string csv, std::string markdown,
                              std::string terminal) {
    ReportCell c;
    c.json = std::isfinite(value) ? nlohmann::json(value) : nlohmann::json();
    c.csv = std::move(csv);
    c.markdown = std::move(markdown);
    c.terminal = std::move(terminal);
    return c;
}

ReportCell ReportCell::count(long long n) {
    ReportCell c;
    c.json = n;
    c.csv = c.markdown = c.terminal = std::to_string(n);
    return c;
}

ReportCell ReportCell::flag(bool value, const std::string& yes, const std::string& no) {
    ReportCell c = text(value ? yes : no);
    c.json = value;
    return c;
}

ReportCell& ReportCell::withoutJson() {
    json = discarded();
    return *this;
}

void ReportTable::addRow(std::vector<ReportCell> cells) {
    if (cells.size() != columns_.size())
        throw std::invalid_argument("a report row has " + std::to_string(cells.size()) +
                                    " cells for " + std::to_string(columns_.size()) + " columns");
    rows_.push_back(std::move(cells));
}

size_t ReportTable::columnIndex(const std::string& key) const {
    for (size_t c = 0; c < columns_.size(); ++c)
        if (columns_[c].key == key) return c;
    return std::string::npos;
}

std::vector<size_t> ReportTable::shown(bool ReportColumn::*flag,
                                       const std::vector<std::string>& keys) const {
    std::vector<size_t> out;
    if (keys.empty()) {
        for (size_t c = 0; c < columns_.size(); ++c)
            if (columns_[c].*flag) out.push_back(c);
        return out;
    }
    for (const std::string& k : keys) {
        const size_t c = columnIndex(k);
        if (c == std::string::npos) throw std::invalid_argument("no report column '" + k + "'");
        out.push_back(c);
    }
    return out;
}

std::string ReportTable::csv(const std::vector<std::string>& keys) const {
    const std::vector<size_t> cols = shown(&ReportColumn::csv, keys);
    std::ostringstream os;
    for (size_t i = 0; i < cols.size(); ++i) {
        const ReportColumn& c = columns_[cols[i]];
        os << (i ? "," : "") << (c.csvHeader.empty() ? c.key : c.csvHeader);
    }
    os << "\n";
    for (const auto& row : rows_) {
        for (size_t i = 0; i < cols.size(); ++i) os << (i ? "," : "") << csvField(row[cols[i]]);
        os << "\n";
    }
    return os.str();
}

std::string ReportTable::markdown(const std::vector<std::string>& keys) const {
    const std::vector<size_t> cols = shown(&ReportColumn::markdown, keys);
    std::ostringstream os;
    os << "|";
    for (size_t c : cols) os << " " << columns_[c].heading << " |";
    os << "\n|";
    for (size_t c : cols) os << columns_[c].markdownRule << "|";
    os << "\n";
    for (const auto& row : rows_) {
        os << "|";
        for (size_t c : cols) os << " " << row[c].markdown << " |";
        os << "\n";
    }
    return os.str();
}

std::string ReportTable::terminal(size_t rows, const std::vector<std::string>& keys) const {
    const std::vector<size_t> cols = shown(&ReportColumn::terminal, keys);
    std::ostringstream os;
    std::string line;
    for (size_t c : cols) {
        const ReportColumn& col = columns_[c];
        const std::string& h = col.terminalHeading.empty() ? col.heading : col.terminalHeading;
        line += col.gap + pad(h, col.width, col.align);
    }
    os << rstrip(line) << "\n";
    const size_t n = rows > 0 ? std::min(rows, rows_.size()) : rows_.size();
    for (size_t r = 0; r < n; ++r) {
        line.clear();
        for (size_t c : cols)
            line += columns_[c].gap +
                    pad(rows_[r][c].terminal, columns_[c].width, columns_[c].align);
        os << rstrip(line) << "\n";
    }
    return os.str();
}

nlohmann::json ReportTable::json() const {
    nlohmann::json out = nlohmann::json::array();
    for (const auto& row : rows_) {
        nlohmann::json j = nlohmann::json::object();
        for (size_t c = 0; c < columns_.size(); ++c)
            if (!columns_[c].json || row[c].json.is_discarded()) continue;
            else if (columns_[c].key.find('/') != std::string::npos)  // nested: "pst/total"
                j[nlohmann::json::json_pointer("/" + columns_[c].key)] = row[c].json;
            else
                j[columns_[c].key] = row[c].json;
        out.push_back(std::move(j));
    }
    return out;
}

std::vector<double> ReportTable::series(const std::string& key) const {
    const size_t c = columnIndex(key);
    if (c == std::string::npos) throw std::invalid_argument("no report column '" + key + "'");
    std::vector<double> out;
    for (const auto& row : rows_)
        out.push_back(row[c].json.is_number() ? row[c].json.get<double>()
                                              : std::numeric_limits<double>::quiet_NaN());
    return out;
}

}  // namespace veil
