#include "app/gui/login_dialog.h"

#include <QDialogButtonBox>
#include <QFormLayout>
#include <QLabel>
#include <QLineEdit>
#include <QPushButton>
#include <QVBoxLayout>

namespace ld::gui {

LoginDialog::LoginDialog(db::Store& store, QWidget* parent) : QDialog(parent), store_(store) {
  firstAdmin_ = !store_.hasUsers();
  setWindowTitle(firstAdmin_ ? tr("First start: create the administrator") : tr("Log in"));
  auto* layout = new QVBoxLayout(this);
  auto* intro = new QLabel(firstAdmin_ ? tr("The trainee store at %1 has no accounts yet.\n"
                                            "Choose the administrator's name and password.")
                                             .arg(QString::fromStdString(store_.location()))
                                       : tr("Trainee store: %1").arg(QString::fromStdString(store_.location())),
                           this);
  intro->setWordWrap(true);
  layout->addWidget(intro);
  auto* form = new QFormLayout;
  name_ = new QLineEdit(this);
  password_ = new QLineEdit(this);
  password_->setEchoMode(QLineEdit::Password);
  form->addRow(tr("Name"), name_);
  form->addRow(tr("Password"), password_);
  if (firstAdmin_) {
    confirm_ = new QLineEdit(this);
    confirm_->setEchoMode(QLineEdit::Password);
    form->addRow(tr("Password again"), confirm_);
  }
  layout->addLayout(form);
  message_ = new QLabel(this);
  message_->setStyleSheet(QStringLiteral("color: #b00020"));
  message_->setWordWrap(true);
  layout->addWidget(message_);
  auto* buttons = new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel, this);
  buttons->button(QDialogButtonBox::Ok)->setText(firstAdmin_ ? tr("Create and log in") : tr("Log in"));
  layout->addWidget(buttons);
  connect(buttons, &QDialogButtonBox::rejected, this, &QDialog::reject);
  connect(buttons, &QDialogButtonBox::accepted, this, [this] {
    if (tryLogin(name_->text(), password_->text(), confirm_ ? confirm_->text() : QString())) accept();
  });
}

QString LoginDialog::error() const { return message_->text(); }

bool LoginDialog::tryLogin(const QString& name, const QString& password, const QString& confirm) {
  message_->clear();
  if (name.trimmed().isEmpty() || password.isEmpty()) {
    message_->setText(tr("Enter a name and a password."));
    return false;
  }
  if (firstAdmin_ && password != confirm) {
    message_->setText(tr("The two passwords differ."));
    return false;
  }
  try {
    session_ = firstAdmin_ ? store_.createFirstAdmin(name.trimmed().toStdString(), password.toStdString())
                           : store_.login(name.trimmed().toStdString(), password.toStdString());
    return true;
  } catch (const db::DbError& e) {
    message_->setText(QString::fromUtf8(e.what()));
    return false;
  }
}

}  // namespace ld::gui
