#pragma once
// Logging in to the trainee store. On the first start (a store without users) the
// dialog creates the administrator instead, asking for the password twice.
#include <QDialog>

#include <optional>

#include "database/store.h"

class QLabel;
class QLineEdit;

namespace ld::gui {

class LoginDialog : public QDialog {
  Q_OBJECT

 public:
  LoginDialog(db::Store& store, QWidget* parent = nullptr);

  [[nodiscard]] bool createsFirstAdmin() const { return firstAdmin_; }
  [[nodiscard]] const std::optional<db::Session>& session() const { return session_; }
  [[nodiscard]] QString error() const;
  // What the OK button does with the fields' contents; true when logged in.
  bool tryLogin(const QString& name, const QString& password, const QString& confirm = {});

 private:
  db::Store& store_;
  bool firstAdmin_ = false;
  QLineEdit* name_ = nullptr;
  QLineEdit* password_ = nullptr;
  QLineEdit* confirm_ = nullptr;
  QLabel* message_ = nullptr;
  std::optional<db::Session> session_;
};

}  // namespace ld::gui
