// The report: builds the figures of every section once (plot.h), then writes them into the HTML
// (base64 PNG) and the PDF (vector pages). Sections follow issue 10's order: the ten-second
// summary, parameters, Kalibr matrices, poses, per inertial sensor, per camera, normalised
// residual histograms, correlation, observability, cross-check, configuration.
#include "ctcal/report/report.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "ctcal/report/plot.h"
#include "ctcal/report/stage_time.h"
#include "ctcal/sensors/rig_yaml.h"
#include "report_builder.h"

namespace ctcal::report {
using namespace detail;  // NOLINT(build/namespaces): the builder and report_format.h's helpers
namespace {

namespace fs = std::filesystem;
constexpr double kPngScale = 1.25;  // PNG pixels per pt: the HTML's figures, --png-dir

std::string Base64(const std::string& in) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((in.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const unsigned v = (static_cast<unsigned char>(in[i]) << 16) |
                       (static_cast<unsigned char>(in[i + 1]) << 8) |
                       static_cast<unsigned char>(in[i + 2]);
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += k[(v >> 6) & 63];
    out += k[v & 63];
  }
  if (i < in.size()) {
    unsigned v = static_cast<unsigned char>(in[i]) << 16;
    if (i + 1 < in.size())
      v |= static_cast<unsigned char>(in[i + 1]) << 8;
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < in.size() ? k[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

const char* kCss = R"(
body{font-family:"DejaVu Sans",Helvetica,Arial,sans-serif;margin:0 auto;max-width:1100px;
padding:16px;color:#222}
h1{margin-bottom:4px}h2{border-bottom:2px solid #ddd;padding-bottom:4px;margin-top:36px}
table{border-collapse:collapse;margin:8px 0;font-size:13px}
td,th{border:1px solid #ddd;padding:3px 8px;text-align:left}th{background:#e8ecf2}
tr:nth-child(even) td{background:#fafafa}
td.status{color:#fff;font-weight:bold;text-align:center}
p.verdict{color:#fff;font-weight:bold;font-size:20px;padding:10px;border-radius:4px}
p.omitted,p.note{color:#666;font-style:italic}
pre{background:#f6f8fa;padding:8px;font-size:12px;overflow-x:auto}
table.params td:last-child{font-family:"DejaVu Sans Mono",monospace;font-size:12px}
img.fig{width:100%;border:1px solid #eee;margin:6px 0}
nav a{margin-right:10px}
)";

}  // namespace

namespace {

RigConfig LoadResult(const std::string& out_dir) {
  const std::string result_path = (fs::path(out_dir) / "result.yaml").string();
  if (!fs::exists(result_path))
    throw std::runtime_error(result_path + ": not found (is " + out_dir +
                             " a folder written by ctcal calibrate?)");
  std::vector<std::string> warnings;
  return LoadRig(result_path, &warnings);
}

ReportOutput Render(const std::string& out_dir, const RigConfig& rig, const ReportData& data,
                    const ReportOptions& options, StageClock* clock) {
  ReportOutput out;
  out.checks = EvaluateChecks(rig, data, options.thresholds);
  Builder builder(rig, data, options, out_dir);
  const std::vector<Section> sections =
      builder.Build(out.checks, (fs::path(out_dir) / "crosscheck.yaml").string());
  out.stages.push_back(clock->Lap("checks and figures' data"));

  if (!options.png_dir.empty())
    fs::create_directories(options.png_dir);

  // The figures drawn, in document order; which of them need a PNG (the HTML's figures other
  // than tables, every figure for --png-dir).
  struct Job {
    const Figure* figure = nullptr;
    bool html_image = false;
    bool png = false;
    std::string bytes;
    double pdf_cpu_s = 0.0, png_cpu_s = 0.0;
  };
  std::vector<Job> jobs;
  for (const Section& s : sections) {
    if (!s.omitted.empty())
      continue;
    for (const auto& f : s.figures) {
      if (!f->HasData())
        continue;  // never an empty figure
      Job j;
      j.figure = f.get();
      // Table-only figures duplicate the HTML tables: the PDF needs them, the HTML does not.
      j.html_image =
          options.html && !std::all_of(f->panels().begin(), f->panels().end(), [](const auto& p) {
            return dynamic_cast<const Table*>(p.get()) || dynamic_cast<const TextPanel*>(p.get());
          });
      j.png = j.html_image || !options.png_dir.empty();
      jobs.push_back(std::move(j));
    }
  }
  // PNGs are drawn and encoded by worker threads (each on its own cairo surface) while this
  // thread writes the PDF pages: on the demo the PNGs are most of the work.
  std::atomic<std::size_t> next{0};
  std::vector<std::string> errors(jobs.size());
  const auto worker = [&]() {
    for (std::size_t i = next++; i < jobs.size(); i = next++) {
      if (!jobs[i].png)
        continue;
      const double cpu0 = ThreadCpuSeconds();
      try {
        jobs[i].bytes = RenderPng(*jobs[i].figure, kPngScale);
      } catch (const std::exception& e) {
        errors[i] = jobs[i].figure->id + ": " + e.what();
      }
      jobs[i].png_cpu_s = ThreadCpuSeconds() - cpu0;
    }
  };
  // `threads` in all: the PDF writer (which then joins the PNG workers) and threads - 1 workers.
  const unsigned threads = std::clamp(options.threads > 0 ? static_cast<unsigned>(options.threads)
                                                          : std::thread::hardware_concurrency(),
                                      2u, 8u);
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t)
    pool.emplace_back(worker);
  std::string pdf_error;
  if (options.pdf) {
    out.pdf_path = (fs::path(out_dir) / "report.pdf").string();
    try {
      PdfDocument pdf(out.pdf_path);
      for (Job& j : jobs) {
        const double cpu0 = ThreadCpuSeconds();
        pdf.AddPage(*j.figure);
        j.pdf_cpu_s = ThreadCpuSeconds() - cpu0;
      }
      out.pdf_pages = pdf.pages();
      pdf.Close();
    } catch (const std::exception& e) {
      pdf_error = e.what();
    }
  }
  worker();
  for (std::thread& t : pool)
    t.join();
  if (!pdf_error.empty())
    throw std::runtime_error(pdf_error);
  for (const std::string& e : errors) {
    if (!e.empty())
      throw std::runtime_error(e);
  }
  out.stages.push_back(clock->Lap("figures"));
  for (const Job& j : jobs)
    out.figure_times.push_back({j.figure->id, j.pdf_cpu_s, j.png_cpu_s});

  std::ostringstream html;
  if (options.html) {
    html << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
         << "<title>ctcal calibration report</title><style>" << kCss << "</style></head><body>\n"
         << "<h1>ctcal calibration report</h1><p>" << Escape(out_dir) << "</p>\n<nav>";
    for (const Section& s : sections)
      html << "<a href=\"#" << s.id << "\">" << Escape(s.heading) << "</a>";
    html << "</nav>\n";
  }
  std::size_t job = 0;
  for (const Section& s : sections) {
    out.section_ids.push_back(s.id);
    html << "<section id=\"" << s.id << "\"><h2>" << Escape(s.heading) << "</h2>\n";
    if (!s.omitted.empty()) {
      out.omitted.push_back(s.id + ": " + s.omitted);
      html << "<p class=\"omitted\">Omitted: " << Escape(s.omitted) << ".</p></section>\n";
      continue;
    }
    html << s.html;
    for (const auto& f : s.figures) {
      if (job >= jobs.size() || jobs[job].figure != f.get())
        continue;  // an empty figure, not drawn
      const Job& j = jobs[job++];
      out.figure_ids.push_back(f->id);
      if (!options.png_dir.empty()) {
        const std::string path = (fs::path(options.png_dir) / (f->id + ".png")).string();
        std::ofstream png(path, std::ios::binary);
        png.write(j.bytes.data(), static_cast<std::streamsize>(j.bytes.size()));
        if (!png)
          throw std::runtime_error(path + ": cannot write PNG");
      }
      if (j.html_image) {
        html << "<img class=\"fig\" id=\"" << f->id << "\" alt=\"" << Escape(f->title)
             << "\" src=\"data:image/png;base64," << Base64(j.bytes) << "\">\n";
      } else if (options.html) {
        html << "<div class=\"figtable\" id=\"" << f->id << "\"></div>\n";
      }
    }
    html << "</section>\n";
  }
  if (options.html) {
    html << "</body></html>\n";
    out.html_path = (fs::path(out_dir) / "report.html").string();
    std::ofstream f(out.html_path);
    f << html.str();
    f.flush();
    if (!f)
      throw std::runtime_error(out.html_path + ": cannot write");
  }
  out.stages.push_back(clock->Lap("html"));
  return out;
}

}  // namespace

ReportOutput RenderReport(const std::string& out_dir, const ReportOptions& options) {
  StageClock clock;
  const RigConfig rig = LoadResult(out_dir);
  std::vector<std::string> names;
  for (const auto& s : rig.sensors)
    names.push_back(s.name);
  const ReportData data = LoadReportData(out_dir, names);
  const StageTime read = clock.Lap("read");
  ReportOutput out = Render(out_dir, rig, data, options, &clock);
  out.stages.insert(out.stages.begin(), read);
  return out;
}

ReportOutput RenderReport(const std::string& out_dir, const ReportData& data,
                          const ReportOptions& options) {
  StageClock clock;
  const RigConfig rig = LoadResult(out_dir);
  const StageTime read = clock.Lap("read");
  ReportOutput out = Render(out_dir, rig, data, options, &clock);
  out.stages.insert(out.stages.begin(), read);
  return out;
}

}  // namespace ctcal::report
