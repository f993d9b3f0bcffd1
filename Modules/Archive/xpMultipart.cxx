#include "xpMultipart.h"

#include "xpError.h"

#include <algorithm>
#include <cctype>
#include <random>

namespace xp
{

namespace
{

std::string Lower(std::string text)
{
  for (char& c : text)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

std::string Trimmed(const std::string& text)
{
  const size_t first = text.find_first_not_of(" \t");
  const size_t last = text.find_last_not_of(" \t");
  return first == std::string::npos ? "" : text.substr(first, last - first + 1);
}

} // namespace

std::string ContentTypeParameter(const std::string& contentType, const std::string& name)
{
  // The fields between ';' outside quotes: a quoted type ("application/dicom") may hold any.
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (char c : contentType)
  {
    if (c == '"')
      quoted = !quoted;
    if (c == ';' && !quoted)
      fields.emplace_back();
    else
      fields.back() += c;
  }
  for (size_t i = 1; i < fields.size(); ++i)
  {
    const size_t equals = fields[i].find('=');
    if (equals == std::string::npos || Lower(Trimmed(fields[i].substr(0, equals))) != Lower(name))
      continue;
    std::string value = Trimmed(fields[i].substr(equals + 1));
    if (value.size() >= 2 && value.front() == '"' && value.back() == '"')
      value = value.substr(1, value.size() - 2);
    return value;
  }
  return "";
}

std::vector<MultipartPart> SplitMultipart(const std::string& body, const std::string& boundary, const std::string& where)
{
  if (boundary.empty() || boundary.size() > 70)
    throw Error(where, "the archive's multipart answer names no usable boundary");
  const std::string delimiter = "--" + boundary;
  // The first delimiter may open the body; every later one follows a line break.
  size_t at = body.compare(0, delimiter.size(), delimiter) == 0 ? 0 : body.find("\r\n" + delimiter);
  if (at == std::string::npos)
    throw Error(where, "the archive's answer is not the multipart it announced (no boundary)");
  at += at == 0 ? delimiter.size() : delimiter.size() + 2;
  std::vector<MultipartPart> parts;
  for (;;)
  {
    if (body.compare(at, 2, "--") == 0)
      return parts; // the closing delimiter
    const size_t lineEnd = body.find("\r\n", at);
    if (lineEnd == std::string::npos)
      throw Error(where, "the archive's multipart answer is cut short after part " + std::to_string(parts.size()));
    const size_t headersEnd = body.find("\r\n\r\n", lineEnd);
    const size_t next = body.find("\r\n" + delimiter, lineEnd);
    if (next == std::string::npos)
      throw Error(where, "the archive's multipart answer is cut short in part " + std::to_string(parts.size() + 1));
    MultipartPart part;
    size_t contentStart = lineEnd + 2; // a part without headers starts with an empty line
    if (body.compare(lineEnd, 4, "\r\n\r\n") == 0)
      contentStart = lineEnd + 4;
    else if (headersEnd != std::string::npos && headersEnd < next)
    {
      const std::string headers = body.substr(lineEnd + 2, headersEnd - lineEnd - 2);
      size_t line = 0;
      while (line < headers.size())
      {
        const size_t end = std::min(headers.find("\r\n", line), headers.size());
        const std::string header = headers.substr(line, end - line);
        const size_t colon = header.find(':');
        if (colon != std::string::npos && Lower(Trimmed(header.substr(0, colon))) == "content-type")
          part.contentType = Trimmed(header.substr(colon + 1));
        line = end + 2;
      }
      contentStart = headersEnd + 4;
    }
    else
      throw Error(where, "the archive's multipart answer has a part without its blank line");
    part.body = body.substr(contentStart, next - contentStart);
    parts.push_back(std::move(part));
    at = next + 2 + delimiter.size();
  }
}

std::string JoinMultipart(const std::vector<std::string>& parts, const std::string& partType, const std::string& boundary)
{
  std::string body;
  for (const std::string& part : parts)
  {
    if (part.find("--" + boundary) != std::string::npos)
      throw Error("multipart", "a part holds the boundary");
    body += "--" + boundary + "\r\nContent-Type: " + partType + "\r\n\r\n";
    body += part;
    body += "\r\n";
  }
  return body + "--" + boundary + "--\r\n";
}

std::string NewBoundary()
{
  static const char letters[] = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789";
  std::random_device device;
  std::uniform_int_distribution<int> pick(0, static_cast<int>(sizeof(letters)) - 2);
  std::string boundary = "xpose-";
  for (int i = 0; i < 32; ++i)
    boundary += letters[pick(device)];
  return boundary;
}

} // namespace xp
