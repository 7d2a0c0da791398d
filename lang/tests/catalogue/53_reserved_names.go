// Functions named like control structures or Signal cannot be declared, nor
// a drone named like the ground station.
package Reserved

var D1 Quadcopter
var GCS Quadcopter

func INIT() {
	D1.Land()
}

func If() {
	D1.Arm()
}

func Signal() {
	D1.Arm()
}
