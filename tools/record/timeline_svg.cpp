#include "timeline_svg.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

namespace plexus::record {

namespace {

// The palette of plexus-timeline-svg, so that a source looks the same in both pictures.
constexpr const char* source_palette[] = {"#00429d", "#e6a100", "#33a02c", "#b2182b", "#7b3294",
                                          "#17becf", "#f781bf", "#666666", "#a6d854", "#fdbf6f"};
constexpr const char* changed_colour = "#d62728";
constexpr const char* dropped_colour = "#bbbbbb";

std::string escape(const std::string& text) {
    std::string out;
    for (const char c : text) {
        switch (c) {
            case '&':
                out += "&amp;";
                break;
            case '<':
                out += "&lt;";
                break;
            case '>':
                out += "&gt;";
                break;
            case '"':
                out += "&quot;";
                break;
            default:
                out += c;
        }
    }
    return out;
}

std::string format(const char* pattern, auto... values) {
    char buffer[512];
    std::snprintf(buffer, sizeof buffer, pattern, values...);
    return buffer;
}

class Picture {
public:
    Picture(double end, int width) : end_(end), width_(width), scale_((width - left - right) / end) {}

    static constexpr int left = 210;
    static constexpr int right = 20;
    static constexpr int lane = 18;
    static constexpr int gap = 6;

    double x(double t) const { return left + std::max(0.0, t) * scale_; }
    void label(const std::string& text, double y_mid, int size = 12) {
        parts_ +=
            format(R"(<text x="%d" y="%.1f" font-size="%d" text-anchor="end" dominant-baseline="middle">)",
                   left - 8, y_mid, size) +
            escape(text) + "</text>\n";
    }
    void mark(double t, double y, double height, const char* colour, const std::string& tip) {
        parts_ += format(R"(<rect x="%.2f" y="%.1f" width="1.2" height="%.1f" fill="%s"><title>)", x(t), y,
                         height, colour) +
                  escape(tip) + "</title></rect>\n";
    }
    void ring(double t, double y_mid, const std::string& tip) {
        parts_ +=
            format(R"(<circle cx="%.2f" cy="%.1f" r="4" fill="none" stroke="%s" stroke-width="1.2"><title>)",
                   x(t) + 0.6, y_mid, changed_colour) +
            escape(tip) + "</title></circle>\n";
    }
    void raw(const std::string& text) { parts_ += text; }
    void axis(int& y) {
        y += 6;
        parts_ +=
            format(R"(<line x1="%d" y1="%d" x2="%d" y2="%d" stroke="#000"/>)", left, y, width_ - right, y) +
            "\n";
        const double step = std::max(1.0, std::round(end_ / 15));
        for (double t = 0; t <= end_ + 1e-9; t += step) {
            parts_ +=
                format(R"(<line x1="%.1f" y1="%d" x2="%.1f" y2="%d" stroke="#000"/>)", x(t), y, x(t), y + 4);
            parts_ += format(R"(<text x="%.1f" y="%d" font-size="10" text-anchor="middle">%g</text>)", x(t),
                             y + 15, t) +
                      "\n";
        }
        parts_ +=
            format(
                R"(<text x="%d" y="%d" font-size="11" text-anchor="end">seconds from the recording's start</text>)",
                width_ - right, y + 28) +
            "\n";
        y += 40;
    }
    const std::string& parts() const { return parts_; }
    int width() const { return width_; }

private:
    double end_;
    int width_;
    double scale_;
    std::string parts_;
};

std::string tip_of(const MessageDecision& decision) {
    return format("%s seq %llu at %.3f s: recorded %s, what-if %s", decision.source.c_str(),
                  static_cast<unsigned long long>(decision.seq), decision.time, decision.recorded.c_str(),
                  decision.what_if.c_str());
}

}  // namespace

std::string timeline_svg(const RecordedPort& port, const WhatIfResult& result, const std::string& title) {
    double end = 1.0;
    for (const auto& decision : result.decisions)
        end = std::max(end, decision.time);
    Picture picture(end, 1400);
    int y = 40;

    // The changed decisions, all sources together: where to look.
    picture.label("changed (" + std::to_string(result.changed) + ")", y + Picture::lane / 2.0);
    for (const auto& decision : result.decisions) {
        if (decision.changed())
            picture.mark(decision.time, y, Picture::lane, changed_colour, tip_of(decision));
    }
    y += Picture::lane + 2 * Picture::gap;

    for (std::size_t c = 0; c < port.connections.size(); ++c) {
        const char* colour = source_palette[c % std::size(source_palette)];
        const auto& summary = result.sources[c];
        for (const bool what_if : {false, true}) {
            const std::string row = summary.source + (what_if ? " what-if" : " recorded");
            picture.label(row, y + Picture::lane / 2.0, 11);
            for (const auto& decision : result.decisions) {
                if (port.messages[decision.message].connection != c ||
                    decision.standing == Standing::undecided)
                    continue;
                const std::string& outcome = what_if ? decision.what_if : decision.recorded;
                const bool delivered = outcome == "delivered";
                const double height = delivered ? Picture::lane : Picture::lane / 3.0;
                const double top = delivered ? y : y + Picture::lane - height;
                picture.mark(decision.time, top, height, delivered ? colour : dropped_colour,
                             tip_of(decision));
                if (what_if && decision.changed())
                    picture.ring(decision.time, y + Picture::lane / 2.0, tip_of(decision));
            }
            y += Picture::lane + (what_if ? 2 * Picture::gap : 2);
        }
    }
    picture.axis(y);

    // Legend: the sources, then what the marks mean.
    int lx = Picture::left;
    std::string legend;
    const auto item = [&](const std::string& name, const std::string& swatch) {
        legend += swatch;
        legend +=
            format(R"(<text x="%d" y="%d" font-size="11">)", lx + 16, y + 10) + escape(name) + "</text>\n";
        lx += 24 + 7 * static_cast<int>(name.size());
        if (lx > picture.width() - 200) {
            lx = Picture::left;
            y += 18;
        }
    };
    for (std::size_t c = 0; c < port.connections.size(); ++c)
        item(port.connections[c].source + " delivered",
             format(R"(<rect x="%d" y="%d" width="12" height="12" fill="%s"/>)", lx, y,
                    source_palette[c % std::size(source_palette)]));
    item("dropped (accept, constraint, priority, auxiliary)",
         format(R"(<rect x="%d" y="%d" width="12" height="12" fill="%s"/>)", lx, y, dropped_colour));
    item("decided otherwise in the what-if",
         format(R"(<circle cx="%d" cy="%d" r="5" fill="none" stroke="%s" stroke-width="1.5"/>)", lx + 6,
                y + 6, changed_colour));
    y += 22;
    std::string subtitle =
        format("%llu messages compared, %llu changed", static_cast<unsigned long long>(result.compared),
               static_cast<unsigned long long>(result.changed));
    std::string svg =
        format(R"(<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="sans-serif">)",
               picture.width(), y + 10) +
        R"(<rect width="100%" height="100%" fill="white"/>)" +
        format(R"(<text x="%d" y="22" font-size="15">)", Picture::left) + escape(title + " — " + subtitle) +
        "</text>\n";
    return svg + picture.parts() + legend + "</svg>\n";
}

}  // namespace plexus::record
