#include "stimulation.hpp"

#include <charconv>
#include <cmath>

#include "plexus/proto/port_name.hpp"

namespace plexus::daemon::arbitration {

namespace {

std::optional<double> number(const std::string& text) {
    double value = 0;
    const char* end = text.data() + text.size();
    auto [stop, ec] = std::from_chars(text.data(), end, value);
    if (ec != std::errc{} || stop != end || !std::isfinite(value))
        return std::nullopt;
    return value;
}

proto::Result<double> number_key(const proto::CarrierParam& param) {
    if (!param.value)
        return proto::Error{"priority key '" + param.key + "' needs a value, e.g. " + param.key + ".0.5"};
    auto value = number(*param.value);
    if (!value)
        return proto::Error{"priority key " + param.key + "." + *param.value + ": expected a number"};
    return *value;
}

/// "ex./face/out:-1,/obj/out:0.5": port names may hold ':', so the weight follows the last one.
proto::Result<std::vector<std::pair<std::string, double>>> weights(const std::string& text) {
    std::vector<std::pair<std::string, double>> list;
    std::size_t start = 0;
    while (start <= text.size()) {
        std::size_t comma = text.find(',', start);
        if (comma == std::string::npos)
            comma = text.size();
        const std::string item = text.substr(start, comma - start);
        const std::size_t colon = item.rfind(':');
        if (colon == std::string::npos)
            return proto::Error{"priority ex." + text + ": '" + item + "' is not SOURCE:WEIGHT"};
        const std::string source = item.substr(0, colon);
        if (auto error = proto::port_name_error(source))
            return proto::Error{"priority ex." + text + ": " + *error};
        auto weight = number(item.substr(colon + 1));
        if (!weight)
            return proto::Error{"priority ex." + text + ": weight '" + item.substr(colon + 1) +
                                "' is not a number"};
        list.emplace_back(source, *weight);
        start = comma + 1;
    }
    return list;
}

}  // namespace

proto::Result<PriorityParams> PriorityParams::from_clause(const proto::Clause& clause) {
    PriorityParams params;
    for (const auto& param : clause.params) {
        if (param.key == "aux") {
            if (param.value)
                return proto::Error{"priority key 'aux' is a flag and takes no value"};
            params.aux = true;
            continue;
        }
        if (param.key == "ex") {
            if (!param.value)
                return proto::Error{"priority key 'ex' needs SOURCE:WEIGHT pairs, e.g. ex./face/out:-1"};
            auto list = weights(*param.value);
            if (!list)
                return list.error();
            params.ex = std::move(*list);
            continue;
        }
        double* target = param.key == "tc"   ? &params.tc
                         : param.key == "tr" ? &params.tr
                         : param.key == "st" ? &params.st
                         : param.key == "bs" ? &params.bs
                                             : nullptr;
        if (!target)
            return proto::Error{"unknown key '" + param.key +
                                "' of recv.priority (keys: tc tr st bs ex aux)"};
        auto value = number_key(param);
        if (!value)
            return value.error();
        *target = *value;
    }
    if (params.tc <= 0)
        return proto::Error{"priority tc must be > 0 seconds"};
    if (params.tr < 0)
        return proto::Error{"priority tr must be >= 0 seconds"};
    if (params.st < 0)
        return proto::Error{"priority st must be >= 0"};
    return params;
}

double Stimulus::level(double t) const {
    if (!ta_)
        return 0;
    const double dt = t - *ta_;
    if (dt > tc_)
        return 0;
    return sa_ * (1 - std::exp(5 * (dt - tc_) / tc_) + std::exp(-5.0));
}

void Stimulus::settle(double t) {
    if (!ta_ || t - *ta_ <= tc_)
        return;
    if (reached_ && tr_ > 0)
        rest_until_ = *ta_ + tc_ + tr_;
    reached_ = false;
    sa_ = 0;
    ta_.reset();
}

void Stimulus::stimulate(double t) {
    settle(t);
    if (resting(t))
        return;
    sa_ = std::min(1.0, level(t) + st_);
    ta_ = t;
    if (sa_ >= 1.0)
        reached_ = true;
}

proto::Result<std::vector<double>> solve_outputs(const std::vector<std::vector<double>>& weights,
                                                 const std::vector<bool>& active,
                                                 const std::vector<double>& bias) {
    std::vector<double> matrix;
    std::vector<double> outputs;
    if (!solve_outputs_into(weights, active, bias, matrix, outputs))
        return proto::Error{"inconsistent weights: the system (I - X*A^T) y = X*beta is singular"};
    return outputs;
}

bool solve_outputs_into(const std::vector<std::vector<double>>& weights, const std::vector<bool>& active,
                        const std::vector<double>& bias, std::vector<double>& matrix, std::vector<double>& outputs) {
    const std::size_t n = bias.size();
    // Row i: y_i - x_i * sum_j alpha_ji * y_j = x_i * beta_i, as an augmented n x (n+1) matrix.
    const std::size_t w = n + 1;
    matrix.assign(n * w, 0.0);
    auto at = [&](std::size_t row, std::size_t col) -> double& { return matrix[row * w + col]; };
    for (std::size_t i = 0; i < n; ++i) {
        const double x = active[i] ? 1.0 : 0.0;
        for (std::size_t j = 0; j < n; ++j)
            at(i, j) = (i == j ? 1.0 : 0.0) - x * weights[j][i];
        at(i, n) = x * bias[i];
    }
    // Gaussian elimination with partial pivoting.
    for (std::size_t col = 0; col < n; ++col) {
        std::size_t pivot = col;
        for (std::size_t row = col + 1; row < n; ++row) {
            if (std::fabs(at(row, col)) > std::fabs(at(pivot, col)))
                pivot = row;
        }
        if (std::fabs(at(pivot, col)) < 1e-9)
            return false;
        if (pivot != col) {
            for (std::size_t k = 0; k <= n; ++k)
                std::swap(at(pivot, k), at(col, k));
        }
        for (std::size_t row = col + 1; row < n; ++row) {
            const double factor = at(row, col) / at(col, col);
            if (factor == 0)
                continue;
            for (std::size_t k = col; k <= n; ++k)
                at(row, k) -= factor * at(col, k);
        }
    }
    outputs.assign(n, 0.0);
    for (std::size_t i = n; i-- > 0;) {
        double sum = at(i, n);
        for (std::size_t k = i + 1; k < n; ++k)
            sum -= at(i, k) * outputs[k];
        outputs[i] = sum / at(i, i);
    }
    return true;
}

std::optional<std::size_t> select_winner(const std::vector<double>& outputs,
                                         const std::vector<bool>& auxiliary) {
    std::optional<std::size_t> winner;
    for (std::size_t i = 0; i < outputs.size(); ++i) {
        if (auxiliary[i] || !(outputs[i] > 1e-12))
            continue;
        // Strictly greater (beyond rounding): an equal output later in the list does not win.
        if (!winner || outputs[i] > outputs[*winner] + 1e-12)
            winner = i;
    }
    return winner;
}

}  // namespace plexus::daemon::arbitration
